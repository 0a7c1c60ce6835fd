"""Independent 3D reference for the Pose2Sim demo, built WITHOUT voxelmocap code.

A development script (not part of the package, not a dependency): it gives
``scripts/bench_real.py`` something to score voxelmocap's silhouettes and tracked landmarks
against on a real recording that has no ground truth.

* 2D: MediaPipe's legacy pose solution (``mediapipe==0.10.14``, ``mp.solutions.pose`` with
  ``model_complexity=1``; its model ships in the wheel and runs offline) on every frame of each of
  the four videos: 33 keypoints with a visibility score, and its person segmentation mask.
* Calibration: Pose2Sim's own Qualisys conversion (``Pose2Sim.calibration.calib_qca_fun``,
  imported from the unpacked wheel, default ``/work/p2s/x``): the sub-pixel ÷ 64 units, the
  ``fov_video`` offset, the column-major rotation, the camera centre and the π flip about x are
  Pose2Sim's, not voxelmocap's reader. Its metres become millimetres here.
* 3D: keypoints undistorted with OpenCV (``cv2.undistortPoints``) and triangulated by the direct
  linear transform (SVD) over the views where MediaPipe's visibility is at least ``--min-vis``;
  a view whose reprojection error exceeds ``--max-reproj`` px is dropped and the point
  re-triangulated while three or more views remain. Every kept point is reprojected with
  ``cv2.projectPoints`` (full distortion) into each view used: the per-point RMS error is stored
  and summarised (the check of the triangulation).

Output folder (``--out``)::

    reference.npz    frames (F,) 1-based, names (33,), points_mm (F, 33, 3) NaN where not
                     triangulated, reproj_px (F, 33) RMS reprojection error, n_views (F, 33),
                     keypoints (C, F, 33, 3) pixels u, v and visibility, cameras (C,)
    masks_<cam>.npz  mask (F, H, W) bool packed with np.packbits along W (key ``packed``,
                     ``shape``); MediaPipe's segmentation > 0.5
    summary.txt      reprojection statistics per camera

Run (about 1–2 min per camera on one core)::

    /work/devvenv/bin/python scripts/reference_pose2sim_demo.py --out /work/p2s_ref

Feeds docs/benchmarks.md, "Real recording (Pose2Sim demo)" and "Silhouettes (Pose2Sim demo)": the
reference ``REF`` that ``bench_real.py`` scores against.
"""

from __future__ import annotations

import argparse
import importlib.metadata as metadata
import os
import sys
import time
from pathlib import Path

import cv2
import numpy as np

DEMO = Path("/work/p2s/x/Pose2Sim/Demo_SinglePerson")
POSE2SIM_ROOT = Path("/work/p2s/x")
#: MediaPipe pose landmark names, in its output order (mp.solutions.pose.PoseLandmark).
NAMES = ["nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
         "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
         "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
         "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip",
         "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel",
         "right_heel", "left_foot_index", "right_foot_index"]


def pose2sim_calibration(qca: Path, pose2sim_root: Path):
    """Cameras from Pose2Sim's own Qualisys conversion: names, sizes, K, dist, R (3×3), T (mm)."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    sys.path.insert(0, str(pose2sim_root))
    real_version = metadata.version

    def version(name):  # the unpacked wheel has no installed metadata; Pose2Sim asks for it
        if name.lower() == "pose2sim":
            return "0.10.49"
        return real_version(name)

    metadata.version = version
    try:
        from Pose2Sim.calibration import calib_qca_fun
    finally:
        metadata.version = real_version
    _, names, sizes, dists, ks, rvecs, ts = calib_qca_fun(str(qca), binning_factor=1)
    cams = []
    for name, size, dist, k, rvec, t in zip(names, sizes, dists, ks, rvecs, ts, strict=True):
        cams.append({"name": name, "size": (int(size[0]), int(size[1])),
                     "K": np.asarray(k, float), "dist": np.asarray(dist, float),
                     "R": cv2.Rodrigues(np.asarray(rvec, float))[0],
                     "T": 1000.0 * np.asarray(t, float)})  # Pose2Sim works in metres
    return cams


def run_mediapipe(video: Path, complexity: int = 1):
    """Keypoints (F, 33, 3) in pixels (u, v, visibility) and masks (F, H, W) bool of one video."""
    import mediapipe as mp

    cap = cv2.VideoCapture(str(video))
    kps, masks = [], []
    with mp.solutions.pose.Pose(static_image_mode=False, model_complexity=complexity,
                                enable_segmentation=True, smooth_landmarks=True) as pose:
        while True:
            ok, bgr = cap.read()
            if not ok:
                break
            h, w = bgr.shape[:2]
            res = pose.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
            kp = np.full((33, 3), np.nan)
            if res.pose_landmarks is not None:
                for i, lm in enumerate(res.pose_landmarks.landmark):
                    kp[i] = (lm.x * w, lm.y * h, lm.visibility)
            kps.append(kp)
            if res.segmentation_mask is not None:
                masks.append(res.segmentation_mask > 0.5)
            else:
                masks.append(np.zeros((h, w), bool))
    cap.release()
    return np.stack(kps), np.stack(masks)


def triangulate(cams, uv, vis, *, min_vis: float, max_reproj: float):
    """DLT over the views with visibility ≥ min_vis, dropping views beyond max_reproj px.

    Parameters
    ----------
    cams : list of dict
    uv : (C, 2) pixel coordinates (NaN where not detected)
    vis : (C,) visibility

    Returns
    -------
    point (3,) mm or NaN, RMS reprojection error (px), number of views used
    """
    use = [c for c in range(len(cams)) if np.isfinite(uv[c]).all() and vis[c] >= min_vis]
    norm = {}
    for c in use:
        norm[c] = cv2.undistortPoints(uv[c].reshape(1, 1, 2), cams[c]["K"],
                                      cams[c]["dist"]).reshape(2)
    while len(use) >= 2:
        rows = []
        for c in use:
            p = np.hstack([cams[c]["R"], cams[c]["T"][:, None]])  # normalised camera: K = I
            x, y = norm[c]
            rows.append(x * p[2] - p[0])
            rows.append(y * p[2] - p[1])
        _, _, vt = np.linalg.svd(np.asarray(rows))
        X = vt[-1, :3] / vt[-1, 3]
        errs = []
        for c in use:
            proj, _ = cv2.projectPoints(X.reshape(1, 3), cv2.Rodrigues(cams[c]["R"])[0],
                                        cams[c]["T"], cams[c]["K"], cams[c]["dist"])
            errs.append(float(np.linalg.norm(proj.reshape(2) - uv[c])))
        errs = np.asarray(errs)
        in_front = all((cams[c]["R"] @ X + cams[c]["T"])[2] > 0 for c in use)
        if errs.max() <= max_reproj and in_front:
            return X, float(np.sqrt(np.mean(errs ** 2))), len(use)
        if len(use) <= 2:
            break
        use = [c for i, c in enumerate(use) if i != int(np.argmax(errs))]
    return np.full(3, np.nan), np.nan, 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--demo", type=Path, default=DEMO)
    ap.add_argument("--pose2sim", type=Path, default=POSE2SIM_ROOT,
                    help="folder holding the Pose2Sim package (its calibration conversion)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--min-vis", type=float, default=0.5)
    ap.add_argument("--max-reproj", type=float, default=25.0)
    ap.add_argument("--complexity", type=int, default=1)
    args = ap.parse_args(argv)

    cams = pose2sim_calibration(next((args.demo / "calibration").glob("*.qca.txt")),
                                args.pose2sim)
    args.out.mkdir(parents=True, exist_ok=True)
    videos = sorted((args.demo / "videos").glob("*.mp4"))
    by_name = {v.stem: v for v in videos}
    keypoints = []
    for cam in cams:
        t0 = time.perf_counter()
        kp, masks = run_mediapipe(by_name[cam["name"]], args.complexity)
        keypoints.append(kp)
        np.savez_compressed(args.out / f"masks_{cam['name']}.npz",
                            packed=np.packbits(masks, axis=2), shape=np.array(masks.shape))
        print(f"{cam['name']}: {len(kp)} frames, image {masks.shape[2]}x{masks.shape[1]} "
              f"(calibration {cam['size'][0]}x{cam['size'][1]}), pose found in "
              f"{int(np.isfinite(kp[:, 0, 0]).sum())}, {time.perf_counter() - t0:.0f} s",
              flush=True)
    keypoints = np.stack(keypoints)                      # (C, F, 33, 3)
    n_cam, n_frames = keypoints.shape[:2]
    points = np.full((n_frames, 33, 3), np.nan)
    reproj = np.full((n_frames, 33), np.nan)
    n_views = np.zeros((n_frames, 33), int)
    for f in range(n_frames):
        for j in range(33):
            X, e, n = triangulate(cams, keypoints[:, f, j, :2], keypoints[:, f, j, 2],
                                  min_vis=args.min_vis, max_reproj=args.max_reproj)
            points[f, j], reproj[f, j], n_views[f, j] = X, e, n
    np.savez(args.out / "reference.npz", frames=np.arange(1, n_frames + 1), names=np.array(NAMES),
             points_mm=points, reproj_px=reproj, n_views=n_views, keypoints=keypoints,
             cameras=np.array([c["name"] for c in cams]))
    ok = np.isfinite(reproj)
    lines = [f"triangulated {ok.sum()} of {ok.size} landmark-frames "
             f"({100 * ok.mean():.1f} %); views used: "
             + ", ".join(f"{k}: {(n_views == k).sum()}" for k in range(2, n_cam + 1)),
             f"RMS reprojection error (px): median {np.nanmedian(reproj):.2f}, mean "
             f"{np.nanmean(reproj):.2f}, 95th percentile {np.nanpercentile(reproj, 95):.2f}"]
    for name in ("left_shoulder", "right_shoulder", "left_hip", "right_hip", "left_knee",
                 "right_knee", "left_ankle", "right_ankle", "left_wrist", "right_wrist"):
        j = NAMES.index(name)
        lines.append(f"  {name:15s} triangulated {ok[:, j].mean() * 100:5.1f} %, median "
                     f"reprojection {np.nanmedian(reproj[:, j]):.2f} px")
    text = "\n".join(lines)
    (args.out / "summary.txt").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
