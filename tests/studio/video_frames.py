"""Video for ss_studio's browser test, and frames read back from it (OpenCV, as ss_studio reads).

  video_frames.py write DATASET VIDEO [--size W,H] [--fps F]
      The dataset's images (metadata.csv, sorted by file name) as one MJPG .avi, each image
      padded to W x H (default 640,480) by repeating its edge pixels, so its boxes keep their
      coordinates. Prints the frame count.
  video_frames.py read VIDEO OUT_DIR INDEX...
      Decodes the video and writes frame INDEX as OUT_DIR/0000.png, 0001.png, ... in the order
      given (the frames ss_calibrate is run on to compare with the studio's calibration).
Errors: a message on stderr, exit 2.
"""
import csv
import os
import sys

import cv2


def fail(message):
    print(f"video_frames: error: {message}", file=sys.stderr)
    sys.exit(2)


def write(dataset, video, size=(640, 480), fps=30.0):
    with open(os.path.join(dataset, "metadata.csv"), newline="") as f:
        files = sorted(row["file_name"] for row in csv.DictReader(f))
    if not files:
        fail(f"'{dataset}/metadata.csv' lists no image")
    out = cv2.VideoWriter(video + ".tmp.avi", cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    if not out.isOpened():
        fail(f"cannot write '{video}' (no MJPG encoder?)")
    for name in files:
        image = cv2.imread(os.path.join(dataset, name), cv2.IMREAD_COLOR)
        if image is None:
            fail(f"cannot read '{name}'")
        h, w = image.shape[:2]
        if w > size[0] or h > size[1]:
            fail(f"'{name}' is {w}x{h}, larger than {size[0]}x{size[1]}")
        out.write(cv2.copyMakeBorder(image, 0, size[1] - h, 0, size[0] - w, cv2.BORDER_REPLICATE))
    out.release()
    os.replace(video + ".tmp.avi", video)
    print(len(files))


def read(video, out_dir, indices):
    capture = cv2.VideoCapture(video)
    if not capture.isOpened():
        fail(f"cannot open '{video}'")
    wanted = {}
    for k, i in enumerate(indices):
        wanted.setdefault(i, []).append(k)
    os.makedirs(out_dir, exist_ok=True)
    i = 0
    while wanted:
        ok, frame = capture.read()
        if not ok:
            fail(f"'{video}' ended at frame {i}; frames {sorted(wanted)} not found")
        for k in wanted.pop(i, []):
            path = os.path.join(out_dir, f"{k:04d}.png")
            if not cv2.imwrite(path + ".tmp.png", frame):
                fail(f"cannot write '{path}'")
            os.replace(path + ".tmp.png", path)
        i += 1


def main(argv):
    if len(argv) >= 3 and argv[0] == "write":
        size, fps = (640, 480), 30.0
        rest = argv[3:]
        while rest:
            if rest[0] == "--size" and len(rest) > 1:
                size = tuple(int(v) for v in rest[1].split(","))
            elif rest[0] == "--fps" and len(rest) > 1:
                fps = float(rest[1])
            else:
                fail(f"unexpected argument '{rest[0]}'")
            rest = rest[2:]
        write(argv[1], argv[2], size, fps)
    elif len(argv) >= 4 and argv[0] == "read":
        try:
            indices = [int(v) for v in argv[3:]]
        except ValueError:
            fail(f"frame indices must be integers, got {argv[3:]}")
        read(argv[1], argv[2], indices)
    else:
        fail("usage: video_frames.py write DATASET VIDEO [--size W,H] [--fps F] | "
             "read VIDEO OUT_DIR INDEX...")


if __name__ == "__main__":
    main(sys.argv[1:])
