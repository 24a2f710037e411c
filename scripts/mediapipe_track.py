"""MediaPipe Face Mesh over a video or a folder of frames, written as Sinew's MediaPipe track.

What it is for: landmark tracks made by the real MediaPipe model (not by projecting Sinew's own
vertices), for `sinew drive` and `sinew eval driver --landmarks` with a driver trained by
`sinew train driver --input mediapipe`. The layout is docs/FIT.md's "MediaPipe Face Mesh": one
JSON object a line, `{"timestamp", "width", "height", "landmarks": [[x, y, z], ...]}`, x and y
normalised by the image's size, z MediaPipe's relative depth; 478 points (the irises refined),
or none where no face was found.

    python3 -m venv .venv-mediapipe && .venv-mediapipe/bin/pip install mediapipe==0.10.14
    .venv-mediapipe/bin/python scripts/mediapipe_track.py VIDEO_OR_FOLDER --out track.jsonl [--fps 30]

VIDEO_OR_FOLDER: a folder of frame_*.png (`sinew render`'s), or a video OpenCV reads
(`performance.y4m`). MediaPipe 0.10.14 is pinned: its wheel carries the Face Mesh models, which
later releases download at run time. The tracker runs in video mode (it follows the face from
frame to frame, as a webcam application does).
"""

import argparse
import glob
import json
import os
import sys


def frames(source):
    import cv2

    if os.path.isdir(source):
        paths = sorted(glob.glob(os.path.join(source, "frame_*.png")))
        if not paths:
            sys.exit(f"{source}: no frame_*.png")
        for p in paths:
            bgr = cv2.imread(p)
            if bgr is None:
                sys.exit(f"{p}: not a picture OpenCV reads")
            yield cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        return
    video = cv2.VideoCapture(source)
    if not video.isOpened():
        sys.exit(f"{source}: not a video OpenCV reads")
    while True:
        ok, bgr = video.read()
        if not ok:
            break
        yield cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source")
    parser.add_argument("--out", required=True)
    parser.add_argument("--fps", type=float, default=30.0)
    args = parser.parse_args()
    import mediapipe as mp

    mesh = mp.solutions.face_mesh.FaceMesh(
        static_image_mode=False,
        max_num_faces=1,
        refine_landmarks=True,
        min_detection_confidence=0.5,
        min_tracking_confidence=0.5,
    )
    lines = []
    found = 0
    for f, rgb in enumerate(frames(args.source)):
        h, w = rgb.shape[:2]
        result = mesh.process(rgb)
        points = []
        if result.multi_face_landmarks:
            found += 1
            points = [[p.x, p.y, p.z] for p in result.multi_face_landmarks[0].landmark]
        lines.append(
            json.dumps(
                {"timestamp": round(f / args.fps, 6), "width": w, "height": h, "landmarks": points},
                separators=(",", ":"),
            )
        )
    tmp = args.out + ".tmp"
    with open(tmp, "w") as out:
        out.write("\n".join(lines) + "\n")
    os.replace(tmp, args.out)
    print(f"{args.out}: {len(lines)} frames, a face found in {found}")


if __name__ == "__main__":
    main()
