#!/usr/bin/env python3
"""track_folder.py: a folder of images or a video to touch events with gestures, through the
shadowsense Python module (what ss_track does, in Python).

    track_folder.py --calibration skin.calib [--model default.ssm] [--fps 30]
                    [--csv events.csv] [--jsonl events.jsonl] [--tuio host:port] INPUT

INPUT is a folder of images (read in name order) or a video file; frames are timed at --fps.
Every touch event and temporal gesture is printed, one line each; --csv / --jsonl also write
them in the project's event schema (docs/output.md). Needs OpenCV's Python module (Debian:
python3-opencv) to read images and videos. Errors: a message on stderr, exit 2.
"""
import argparse
import os
import pathlib
import sys

import shadowsense as ss

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"}


def frames(path):
    """The input's frames as HxWx3 uint8 BGR arrays."""
    import cv2  # only needed to read the input

    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise ValueError(f"{path}: no images ({', '.join(sorted(IMAGE_SUFFIXES))})")
        for f in files:
            image = cv2.imread(str(f), cv2.IMREAD_COLOR)
            if image is None:
                raise ValueError(f"{f}: not a readable image")
            yield image
        return
    video = cv2.VideoCapture(str(path))
    if not video.isOpened():
        raise ValueError(f"{path}: neither a folder of images nor a readable video")
    while True:
        ok, image = video.read()
        if not ok:
            return
        yield image


def default_model():
    """The shipped model: beside an installed tree, or in the source tree."""
    here = pathlib.Path(__file__).resolve()
    for candidate in (here.parents[2] / "models" / "default.ssm",
                      here.parents[2] / "share" / "shadowsense" / "models" / "default.ssm"):
        if candidate.is_file():
            return str(candidate)
    return os.environ.get("SHADOWSENSE_MODEL", "default.ssm")


def describe(frame_index, e):
    where = f" at ({e.position[0]:.1f}, {e.position[1]:.1f})" if e.position else ""
    direction = f" {e.direction}" if e.direction != "none" else ""
    return (f"frame {frame_index} {e.timestamp_ms:.1f} ms: track {e.track_id} "
            f"{e.from_state} -> {e.to_state}{direction}{where}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input", type=pathlib.Path, help="a folder of images or a video file")
    parser.add_argument("--calibration", required=True, help="a calibration file (ss_calibrate)")
    parser.add_argument("--model", default=default_model(), help="a model file (.ssm)")
    parser.add_argument("--fps", type=float, default=30.0, help="frame rate of the input")
    parser.add_argument("--csv", help="write the events as CSV to this file")
    parser.add_argument("--jsonl", help="write the events as JSON lines to this file")
    parser.add_argument("--tuio", help="send TUIO to host:port")
    parser.add_argument("--version", action="version", version=f"%(prog)s {ss.__version__}")
    args = parser.parse_args()
    if not args.fps > 0:
        parser.error(f"--fps is {args.fps}; expected a frame rate > 0")

    sense = ss.Runtime(ss.TouchPipeline(ss.Segmenter(ss.load_calibration(args.calibration))),
                       ss.Classifier(args.model))
    sinks = []
    if args.csv:
        sinks.append(ss.CsvSink(args.csv, source=str(args.input)))
    if args.jsonl:
        sinks.append(ss.JsonLinesSink(args.jsonl, source=str(args.input)))
    if args.tuio:
        host, _, port = args.tuio.rpartition(":")
        sinks.append(ss.TuioSink(host or "127.0.0.1", int(port)))

    def report(r):
        for e in r.touch.events:
            print(describe(r.frame_index, e))
        for g in r.touch_gestures:
            shape = f" ({g.hand_shape})" if g.hand_shape else ""
            print(f"frame {r.frame_index} {g.decided_ms:.1f} ms: {g.gesture} {g.phase}, "
                  f"track {g.track_id}{shape}")
        for sink in sinks:
            sink.write(sense.output())

    step = 1000.0 / args.fps
    t = 0.0
    for image in frames(args.input):
        t += step
        report(sense.update(image, t))
    report(sense.flush(t + step))
    for sink in sinks:
        if hasattr(sink, "close"):
            sink.close()  # the event files appear, complete


if __name__ == "__main__":
    try:
        main()
    except (ss.Error, ValueError, OSError) as e:
        print(f"track_folder.py: {e}", file=sys.stderr)
        sys.exit(2)
