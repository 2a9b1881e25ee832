"""How late the body's turn follows its wheels on a DRIVE run (docs/closed-loop.md).

    python3 examples/body_lag.py data/warthog_grass_2024-08-08.csv.gz [RUN.csv ...]

Over the transient windows (a command's first 2 s, where the wheels change speed), the IMU's
yaw rate against the yaw rate the encoders imply (eq. 4: wheel radius times the right wheel's
speed minus the left's, over the baseline) passed through a first-order lag of time constant
tau, started at the window's first sample, times one gain fitted by least squares; for each
tau of a grid, the RMS residual. The tau with the smallest residual is how late the body
answers its wheels (0: at once). The IMU's sign is taken from the data (a run whose IMU reads
the turn backwards is read negated). Standard library only; the sidecar (RUN.meta.json or
RUN.json beside the CSV, or data/*.meta.json for a bundled .csv.gz) gives the geometry.
"""
import csv, gzip, json, math, os, sys

TAUS = [0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5]


def sidecar(path):
    base = path[:-3] if path.endswith(".gz") else path
    base = base[:-4] if base.endswith(".csv") else base
    for candidate in (base + ".csv.meta.json", base + ".meta.json", base + ".json"):
        if os.path.exists(candidate):
            with open(candidate) as f:
                return json.load(f)
    sys.exit(f"{path}: no sidecar found beside it")


def transient_windows(path):
    opener = gzip.open if path.endswith(".gz") else open
    windows = {}
    with opener(path, "rt") as f:
        for row in csv.DictReader(f):
            if row["phase"] == "transient":
                windows.setdefault(row["window"], []).append(row)
    return list(windows.values())


def lagged(values, tau, dt):
    share = 1.0 if tau == 0 else 1.0 - math.exp(-dt / tau)
    out, state = [], values[0]
    for v in values:
        state += share * (v - state)
        out.append(state)
    return out


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for path in sys.argv[1:]:
        side = sidecar(path)
        geometry = side.get("vehicle", side)  # a simulated run's sidecar nests it
        radius, baseline = geometry["wheel_radius"], geometry["baseline"]
        dt = 1.0 / side["rate_hz"]
        pairs = []
        for rows in transient_windows(path):
            wheels = [radius * (float(r["enc_right"]) - float(r["enc_left"])) / baseline for r in rows]
            imu = [float(r["imu_yaw_rate"]) for r in rows]
            if len(rows) >= 10:
                pairs.append((wheels, imu))
        if not pairs:
            print(f"{path}: no transient window of ten samples")
            continue
        sign = 1.0 if sum(a * b for w, i in pairs for a, b in zip(w, i)) >= 0 else -1.0
        scores = []
        for tau in TAUS:
            p = [x for w, _ in pairs for x in lagged(w, tau, dt)]
            y = [sign * x for _, i in pairs for x in i]
            pp = sum(a * a for a in p)
            gain = sum(a * b for a, b in zip(p, y)) / pp if pp > 0 else 0.0
            rms = math.sqrt(sum((b - gain * a) ** 2 for a, b in zip(p, y)) / len(y))
            scores.append((rms, tau, gain))
        rms, tau, gain = min(scores)
        flipped = " (IMU read negated)" if sign < 0 else ""
        print(f"{os.path.basename(path)}: body yaw lag {tau:.2f} s, gain {gain:.2f}, RMS {rms:.3f} rad/s "
              f"(at once: {scores[0][0]:.3f}){flipped}; {len(pairs)} transient windows")


if __name__ == "__main__":
    main()
