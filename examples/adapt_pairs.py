"""drive adapt on every ordered pair of a robot's runs (docs/adaptation.md).

Run from the repository root after `cargo build --release`:

    python3 examples/adapt_pairs.py                 # the seven bundled Warthog runs
    python3 examples/adapt_pairs.py --dir RUNS      # every window CSV in RUNS (one robot)
    python3 examples/adapt_pairs.py -- --models slip-blr   # after --: extra drive adapt arguments
    python3 examples/adapt_pairs.py --library       # also a terrain library of the other runs

Prints, per learner and time, the medians over the pairs of the adaptive model's errors over
the own fit's, the prior's (frozen) and the fit from scratch's (translational, rotational),
and the worst ratio to the prior over the pairs of two runs on the same terrain (the
sidecar's terrain; the paper's run, whose terrain is not recorded, with none). A pair drive
adapt refuses is printed with its reason and left out. With --library, each pair's terrain
library is every other run (neither the prior nor the target: `drive adapt --library`),
and the same ratios are printed for the blend (`library`) too.
"""
import argparse, concurrent.futures, itertools, json, os, statistics as st, subprocess

parser = argparse.ArgumentParser()
parser.add_argument("--dir", help="a directory of window CSVs with their sidecars (default: the bundled Warthog runs)")
parser.add_argument("--jobs", type=int, default=2)
parser.add_argument("--library", action="store_true", help="blend a terrain library of the other runs (drive adapt --library)")
parser.add_argument("extra", nargs="*", help="arguments for drive adapt (after --)")
args = parser.parse_args()

BUNDLED = ["warthog_asphalt_2024-08-07", "warthog_asphalt_2024-09-20a", "warthog_asphalt_2024-09-20b",
           "warthog_asphalt_a", "warthog_asphalt_slow_2024-08-08", "warthog_grass_2024-08-08", "warthog_drive"]
if args.dir:
    runs = {f[:-4]: os.path.join(args.dir, f) for f in sorted(os.listdir(args.dir)) if f.endswith(".csv")}
else:
    runs = {r: f"bundled:{r}" for r in BUNDLED}


def terrain(name):
    """The sidecar's terrain; None where it is unknown (the paper's run: gravel or ice)."""
    path = runs[name]
    if path.startswith("bundled:"):
        sidecar = os.path.join("data", name + ".meta.json")
    else:
        sidecar = next((p for p in (path[:-4] + ".meta.json", path[:-4] + ".json") if os.path.exists(p)), None)
    try:
        t = json.load(open(sidecar)).get("terrain") or None
        return None if t is None or t.startswith("unknown") else t
    except (OSError, TypeError, ValueError):
        return None


def adapt(pair):
    a, b = pair
    library = ["--library", ",".join(runs[r] for r in runs if r not in (a, b))] if args.library else []
    out = subprocess.run(["target/release/drive", "adapt", "--prior", runs[a], "--data", runs[b], "--json"]
                         + library + args.extra, capture_output=True, text=True)
    return a, b, (json.loads(out.stdout) if out.returncode == 0 else out.stderr.strip()[:200])


with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
    results = list(pool.map(adapt, itertools.permutations(runs, 2)))
rows = []
for a, b, d in results:
    if isinstance(d, str):
        print("refused", a, b, d)
    else:
        rows.append((a, b, d))
learners = sorted({p["learner"] for _, _, d in rows for p in d["curve"]})
for learner in learners:
    print("==", learner)
    for shown in ["adaptive", "library"] if args.library else ["adaptive"]:
        for t in sorted({p["t_s"] for _, _, d in rows for p in d["curve"]}):
            ratios = {"own": [], "frozen": [], "scratch": []}
            same_worst, n = 0.0, 0
            for a, b, d in rows:
                pts = {p["model"]: p for p in d["curve"] if p["learner"] == learner and p["t_s"] == t}
                if shown not in pts:
                    continue
                n += 1
                ad = pts[shown]
                for ref in ratios:
                    r = pts[ref]
                    if r["translational_median_m"] is None:
                        continue
                    ratios[ref].append((ad["translational_median_m"] / r["translational_median_m"],
                                        ad["rotational_median_rad"] / r["rotational_median_rad"]))
                if terrain(a) is not None and terrain(a) == terrain(b):
                    fr = pts["frozen"]
                    same_worst = max(same_worst, ad["translational_median_m"] / fr["translational_median_m"],
                                     ad["rotational_median_rad"] / fr["rotational_median_rad"])
            med = {k: (round(st.median([x[0] for x in v]), 3), round(st.median([x[1] for x in v]), 3)) if v else None
                   for k, v in ratios.items()}
            print(f"{shown} t={t:>5g} pairs={n:>2} {shown}/own={med['own']} /frozen={med['frozen']} "
                  f"/scratch={med['scratch']} same-terrain worst vs frozen={same_worst:.3f}")
