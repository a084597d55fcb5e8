#!/usr/bin/python3
"""Scores the mean-softmax ensemble of gesture models (and each member alone) on gesture folders,
in PyTorch with tools/train.py's preprocessing (the C++ Preprocessor's path). It answers what a
distilled model (tools/train.py --teacher) could at best inherit from its teachers: an ensemble of
N models costs N forward passes, so it is not a shippable model itself. Each member's own figures
are printed beside the ensemble's so they can be checked against ss_eval_classify --score
(models/score_scaled_holdouts.py) on the same folders. Colour-input models only.
usage: models/score_ensemble.py --sets DIR[,DIR...] MODEL.ssm MODEL.ssm ...
Prints per folder the accuracy and per-class recall (classes in the first model's order), and over
all folders pooled the minimum and mean per-class recall and the overall accuracy."""
import argparse
import os
import sys

import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import dataset_reader  # noqa: E402
import ss_version  # noqa: E402
import train  # noqa: E402


def scores(models, rows, pre, classes):
    """Per model and for the ensemble (last), the predicted class index of every row."""
    x, y, dark = train.cache(rows, pre, pre["lighting_normalise"], classes, "frames")
    probs = []
    with torch.no_grad():
        for m in models:
            p = []
            for i in range(0, len(y), 64):
                inp = train.photometric(x[i:i + 64], dark[i:i + 64], pre,
                                        pre["lighting_normalise"])
                p.append(F.softmax(m(inp), dim=1))
            probs.append(torch.cat(p))
    probs.append(torch.stack(probs).mean(0))
    return [p.argmax(1) for p in probs], y


def line(name, pred, y, n):
    conf = torch.zeros(n, n, dtype=torch.long)
    for t, p in zip(y.tolist(), pred.tolist()):
        conf[t, p] += 1
    rec = [conf[i, i].item() / conf[i].sum().item() if conf[i].sum() else None for i in range(n)]
    acc = conf.diag().sum().item() / conf.sum().item()
    print(f"  {name:28s} acc {100 * acc:6.2f}%  recall " +
          " ".join("    -" if r is None else f"{100 * r:5.1f}" for r in rec))
    return conf


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sets", required=True, help="comma-separated gesture folders")
    ap.add_argument("models", nargs="+", help="model files (the same classes and input)")
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
    args = ap.parse_args()
    torch.set_num_threads(1)
    _, pre, classes, _ = train.read_model_file(args.models[0])
    if pre.get("input_encoding", "colour") != "colour":
        ap.error(f"{args.models[0]}: input encoding {pre['input_encoding']}: colour models only")
    models = train.load_teachers(args.models, classes, pre, ap.error)
    names = [os.path.basename(m) for m in args.models] + ["ensemble (mean softmax)"]
    pooled = [torch.zeros(len(classes), len(classes), dtype=torch.long) for _ in names]
    for d in args.sets.split(","):
        print(f"== {d}")
        rows = dataset_reader.rows_for_training(d)
        preds, y = scores(models, rows, pre, classes)
        for k, (name, pred) in enumerate(zip(names, preds)):
            pooled[k] += line(name, pred, y, len(classes))
    print(f"== pooled ({', '.join(classes)})")
    for name, conf in zip(names, pooled):
        rec = [conf[i, i].item() / conf[i].sum().item() for i in range(len(classes))
               if conf[i].sum()]
        worst = min(range(len(rec)), key=lambda i: rec[i])
        present = [c for i, c in enumerate(classes) if conf[i].sum()]
        print(f"  {name:28s} min recall {100 * rec[worst]:.2f}% ({present[worst]}), mean recall "
              f"{100 * sum(rec) / len(rec):.2f}%, overall "
              f"{100 * conf.diag().sum().item() / conf.sum().item():.2f}%")


if __name__ == "__main__":
    main()
