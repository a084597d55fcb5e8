#!/usr/bin/python3
"""Scores gesture models on the generator hold-outs g and hold at every pre-registered scale
(models/make_scaled_holdouts.sh) with ss_eval_classify --score --session-calibrations (each
session's own empty-skin model for a calibrated input encoding; a colour model does not read
them; no --lighting-normalise: every model file records its own), and prints per set accuracy
and per-class recall, and over all sets pooled the minimum and mean per-class recall: the
selection rule of the issue-21 protocol (docs/validation_protocol.md: the highest pooled
minimum recall wins; ties within one frame go to the higher mean).
usage: models/score_scaled_holdouts.py NAME=MODEL.ssm[:FILL] ...
  :FILL  bring every frame of a set at scale S to the network's scale: the camera's scale is
         S x 7.578125 px per cm (ss_eval_classify --camera-px-per-cm, --scale-fill FILL with
         FILL black, replicate or black_frame_contrast; docs/input_encodings.md)
environment: SCALES (comma-separated subset of 0.6,0.7,1,1.5,2 to score and pool; default all),
SETS (comma-separated folders under HOLDOUTS to pool instead of g and hold at SCALES, e.g.
realhand_s1/gestures with HOLDOUTS=/work/valsets: the rendered real-hand sources; the scale of
FILL is then read from the folder's first "_s" part),
SS_EVAL_CLASSIFY (default build/examples/ss_eval_classify), HOLDOUTS (default
/work/hands-sets), SCORE_CACHE (json per model and set, default /work/hands-logs/gen; a cached
file is reused, so give every model its own NAME)."""
import json, os, subprocess, sys
SCALES = os.environ.get("SCALES", "0.6,0.7,1,1.5,2").split(",")
SETS = (os.environ["SETS"].split(",") if os.environ.get("SETS")
        else [f"{s}_s{z}" for z in SCALES for s in ("g", "hold")])
NETWORK_PX_PER_CM = 242.5 / 32.0  # FrameEncoder's network_scale (sim::Rig::robot())
WIDTH = max(9, max(len(s) for s in SETS))  # set names line up in the printed table
BIN = os.environ.get("SS_EVAL_CLASSIFY", "build/examples/ss_eval_classify")
SETS_DIR = os.environ.get("HOLDOUTS", "/work/hands-sets")
CACHE = os.environ.get("SCORE_CACHE", "/work/hands-logs/gen")
CLASSES = ["nothing", "hug", "palm", "point", "punch", "two_hands"]
os.makedirs(CACHE, exist_ok=True)
for arg in sys.argv[1:]:
    name, model = arg.split("=", 1)
    model, _, fill = model.partition(":")
    pooled = [[0] * 6 for _ in range(6)]
    missing = 0
    print(f"== {name} ({model})")
    for s in SETS:
        data = f"{SETS_DIR}/{s}"
        if not os.path.exists(f"{data}/metadata.csv"):
            print(f"  {s}: missing")
            missing += 1
            continue
        out = f"{CACHE}/{name}_{s.replace('/', '_')}.json"
        if not os.path.exists(out):
            scale = []
            if fill:
                px = float(s.split("_s")[1].split("/")[0]) * NETWORK_PX_PER_CM
                scale = ["--camera-px-per-cm", repr(px), "--scale-fill", fill]
            subprocess.run([BIN, "--score", model, "--data", data, "--session-calibrations",
                            "--quiet", "--json", out] + scale,
                           check=True, stdout=subprocess.DEVNULL)
        j = json.load(open(out))
        c = j["confusion"]["all"]
        rec = [c[i][i] / sum(c[i]) if sum(c[i]) else None for i in range(6)]
        for i in range(6):
            for k in range(6):
                pooled[i][k] += c[i][k]
        print(f"  {s:{WIDTH}s} acc {100 * j['accuracy']['all']:6.2f}%  recall " +
              " ".join("    -" if r is None else f"{100 * r:5.1f}" for r in rec))
    # Classes with no frame in the pool (a source without fists) take no part in min and mean.
    rec = {CLASSES[i]: pooled[i][i] / sum(pooled[i]) for i in range(6) if sum(pooled[i])}
    if missing:
        print(f"  INCOMPLETE: {missing} of {len(SETS)} sets missing from the pool")
    if not rec:
        sys.exit("score_scaled_holdouts.py: no frame in any set")
    worst = min(rec, key=rec.get)
    right = sum(pooled[i][i] for i in range(6))
    total = sum(map(sum, pooled))
    print(f"  pooled    min recall {100 * rec[worst]:.2f}% ({worst}), mean recall "
          f"{100 * sum(rec.values()) / len(rec):.2f}%, overall {100 * right / total:.2f}% "
          f"({right}/{total})  per class " +
          " ".join(f"{100 * rec[c]:5.1f}" if c in rec else "    -" for c in CLASSES))
