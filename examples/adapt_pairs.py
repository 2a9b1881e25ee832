"""drive adapt on every ordered pair of the bundled Warthog runs (docs/adaptation.md).

Run from the repository root after `cargo build --release`; extra arguments go to drive adapt.
Prints, per learner and time, the medians over the pairs of the adaptive model's errors over
the own fit's, the prior's (frozen) and the fit from scratch's (translational, rotational),
and the worst ratio to the prior over the pairs of two asphalt runs (the same ground).
"""
import json, subprocess, itertools, statistics as st, sys
runs = ["warthog_asphalt_2024-08-07","warthog_asphalt_2024-09-20a","warthog_asphalt_2024-09-20b","warthog_asphalt_a","warthog_asphalt_slow_2024-08-08","warthog_grass_2024-08-08","warthog_drive"]
terrain = lambda r: "grass" if "grass" in r else ("drive" if r=="warthog_drive" else "asphalt")
extra = sys.argv[1:]
rows = []
for a, b in itertools.permutations(runs, 2):
    out = subprocess.run(["target/release/drive","adapt","--prior",f"bundled:{a}","--data",f"bundled:{b}","--json"]+extra, capture_output=True, text=True)
    if out.returncode != 0:
        print("FAIL", a, b, out.stderr.strip()[:200]); continue
    d = json.loads(out.stdout)
    rows.append((a, b, d))
for learner in ["slip-blr","slip-ipem"]:
    print("==", learner)
    for t in [0,15,30,60,120]:
        ratios = {"own":[], "frozen":[], "scratch":[]}
        same_worst = 0
        n = 0
        for a,b,d in rows:
            pts = {p["model"]: p for p in d["curve"] if p["learner"]==learner and p["t_s"]==t}
            if "adaptive" not in pts: continue
            n += 1
            ad = pts["adaptive"]
            for ref in ratios:
                r = pts[ref]
                if r["translational_median_m"] is None: continue
                ratios[ref].append((ad["translational_median_m"]/r["translational_median_m"], ad["rotational_median_rad"]/r["rotational_median_rad"]))
            if terrain(a)==terrain(b)=="asphalt":
                fr = pts["frozen"]
                w = max(ad["translational_median_m"]/fr["translational_median_m"], ad["rotational_median_rad"]/fr["rotational_median_rad"])
                same_worst = max(same_worst, w)
        med = {k: (round(st.median([x[0] for x in v]),3), round(st.median([x[1] for x in v]),3)) if v else None for k,v in ratios.items()}
        print(f"t={t:>3} pairs={n:>2} adaptive/own={med['own']} /frozen={med['frozen']} /scratch={med['scratch']} same-terrain worst vs frozen={same_worst:.3f}")
