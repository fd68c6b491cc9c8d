"""A small example drivestudio folder made from real KITTI object frames (nvrq layer, a script).

``python -m nvrq.examples.kitti_drivestudio KITTI OUT`` writes, for each KITTI object frame of
``KITTI`` (``image_2/``, ``calib/``, ``label_2/``; e.g. the three frames of ``../shared/realdata``,
which may not be copied into the repository: this script makes the example where they are):

``OUT/drivestudio/FRAME/``
    the frame in drivestudio's KITTI-raw layout (one frame, one camera), ready for
    ``nvrq import drivestudio OUT/drivestudio/FRAME SCENE --dataset kitti --offsets 0,1``;
``OUT/renders-sharp/FRAME/0000i.png``, ``OUT/renders-blurry/FRAME/0000i.png``
    stand-ins for two reconstruction methods' renders of that scene's render plan at the
    offsets :data:`OFFSETS` (one camera, one frame: one plan row per offset, in offset order,
    ``00000.png``, ``00001.png`` in the ``order`` layout), so that a user without a trained
    model can try import -> render plan -> renders back -> leaderboard
    (docs/guides/real-data.md). The stand-in of the recorded view is the GT image blurred with
    a Gaussian of sigma 1 and 4 px. The stand-in of an off-path view (the camera ``y`` metres to
    the left) is that blurred image shifted right by the disparity ``fx * y / Z`` of the
    objects' median depth ``Z``: a crude view synthesis, right at that one depth only, so that
    nearer and farther objects come out misplaced in it, as they do in a poor off-path render.

The layout follows datasets/kitti/kitti_preprocess.py of drivestudio: camera 0 is the rectified
left colour camera (``images/000_0.jpg``, ``intrinsics/0.txt`` = ``K_cam2`` with zero
distortion), ``extrinsics/0.txt = inv(T_cam2_velo)`` with pykitti's ``T_cam2_velo = T2 @ R0_rect
@ Tr_velo_to_cam`` (``T2`` the x shift ``P2[0, 3] / P2[0, 0]``), the ego frame is the Velodyne
frame and ``ego_pose/000.txt`` its pose (the identity: one frame), and each object's
``obj_to_world`` puts the box centre ``h / 2`` above the bottom centre along the Velodyne z, with
the tracklet's yaw about it. KITTI's object labels give the bottom centre in the rectified camera
0 frame and ``rotation_y``; the Velodyne yaw is ``-rotation_y - pi / 2`` (the KITTI devkit's
conversion between the two frames).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

__all__ = ["DYNAMIC", "STAND_IN_SIGMAS", "OFFSETS", "write_kitti_layout", "stand_in", "make_example",
           "main"]

#: The KITTI types drivestudio keeps as dynamic objects (kitti_preprocess.py).
DYNAMIC = ("Pedestrian", "Person_sitting", "Cyclist", "Car", "Van", "Truck", "Tram")
#: Stand-in methods: name -> Gaussian blur sigma (pixels) applied to the GT image.
STAND_IN_SIGMAS = {"sharp": 1.0, "blurry": 4.0}
#: The lateral offsets (m, + = left) of the example's views: the recorded one and one off the path;
#: ``nvrq import drivestudio ... --offsets 0,1`` plans the same views.
OFFSETS = (0.0, 1.0)


def _calib(path: Path) -> dict:
    out = {}
    for line in path.read_text().splitlines():
        key, _, rest = line.partition(":")
        if rest.strip():
            out[key.strip()] = np.array([float(v) for v in rest.split()])
    return out


def _h(M) -> np.ndarray:
    T = np.eye(4)
    T[: M.shape[0], : M.shape[1]] = M
    return T


def write_kitti_layout(kitti: Path, frame: str, root: Path):
    """Write KITTI object frame ``frame`` of ``kitti`` as drivestudio's KITTI-raw layout at ``root``.

    Parameters
    ----------
    kitti : pathlib.Path
        The KITTI object folder (``image_2/``, ``calib/`` with ``P2``, ``R0_rect``,
        ``Tr_velo_to_cam``, ``label_2/``).
    frame : str
        The frame id, e.g. ``'000001'``.
    root : pathlib.Path
        The folder to write (created).

    Returns
    -------
    pandas.DataFrame
        The labels of the objects written (:data:`DYNAMIC` types), in ``instances`` key order.
    """
    import cv2

    from nvrq.sources.kitti import read_labels

    cal = _calib(kitti / "calib" / f"{frame}.txt")
    P2 = cal["P2"].reshape(3, 4)
    T2 = np.eye(4)
    T2[0, 3] = P2[0, 3] / P2[0, 0]
    rect_velo = _h(cal["R0_rect"].reshape(3, 3)) @ _h(cal["Tr_velo_to_cam"].reshape(3, 4))  # velo -> rect cam 0
    for sub in ("images", "intrinsics", "extrinsics", "ego_pose", "instances"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    img = cv2.imread(str(kitti / "image_2" / f"{frame}.png"))
    cv2.imwrite(str(root / "images" / "000_0.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 95])
    np.savetxt(root / "intrinsics" / "0.txt", [P2[0, 0], P2[1, 1], P2[0, 2], P2[1, 2], 0, 0, 0, 0, 0])
    np.savetxt(root / "extrinsics" / "0.txt", np.linalg.inv(T2 @ rect_velo))
    np.savetxt(root / "ego_pose" / "000.txt", np.eye(4))
    labels = read_labels(kitti / "label_2" / f"{frame}.txt")
    labels = labels[labels["type"].isin(DYNAMIC)].reset_index(drop=True)
    info = {}
    for i, o in labels.iterrows():
        bottom = np.linalg.inv(rect_velo) @ [o["x"], o["y"], o["z"], 1.0]
        yaw = -o["rotation_y"] - np.pi / 2
        c, s = np.cos(yaw), np.sin(yaw)
        o2v = np.array([[c, -s, 0, bottom[0]], [s, c, 0, bottom[1]], [0, 0, 1, bottom[2] + o["h"] / 2],
                        [0, 0, 0, 1]])
        info[str(i)] = {"id": i, "class_name": o["type"],
                        "frame_annotations": {"frame_idx": [0], "obj_to_world": [o2v.tolist()],
                                              "box_size": [[o["l"], o["w"], o["h"]]]}}
    (root / "instances" / "instances_info.json").write_text(json.dumps(info))
    (root / "instances" / "frame_instances.json").write_text(json.dumps({"0": [int(k) for k in info]}))
    return labels


def stand_in(gt: np.ndarray, *, sigma: float, shift_px: float) -> np.ndarray:
    """A stand-in render: ``gt`` blurred with a Gaussian of ``sigma`` px, then moved right by
    ``shift_px`` (bilinear, the border repeated).

    Parameters
    ----------
    gt : numpy.ndarray
        (H, W, 3) uint8 image.
    sigma : float
        Blur in pixels.
    shift_px : float
        Shift to the right in pixels (0: the recorded view).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) uint8 image.

    >>> im = np.zeros((4, 6, 3), np.uint8); im[:, 2] = 90
    >>> int(np.argmax(stand_in(im, sigma=0.1, shift_px=2.0)[0, :, 0]))
    4
    """
    import cv2

    out = cv2.GaussianBlur(gt, (0, 0), sigma)
    if shift_px:
        M = np.array([[1.0, 0.0, shift_px], [0.0, 1.0, 0.0]])
        out = cv2.warpAffine(out, M, (gt.shape[1], gt.shape[0]), flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)
    return out


def make_example(kitti, out) -> list[Path]:
    """Write the example (module docstring) for every frame of ``kitti`` into ``out``.

    Parameters
    ----------
    kitti : str or os.PathLike
        The KITTI object folder.
    out : str or os.PathLike
        The example folder (``drivestudio/``, ``renders-sharp/``, ``renders-blurry/``).

    Returns
    -------
    list of pathlib.Path
        The drivestudio folders written, one per frame.

    Raises
    ------
    InputError
        ``kitti`` holds no ``image_2/*.png``.
    """
    import cv2

    from data_schema.errors import InputError

    kitti, out = Path(kitti), Path(out)
    frames = sorted(p.stem for p in (kitti / "image_2").glob("*.png"))
    if not frames:
        raise InputError(kitti / "image_2", None, "KITTI object frames (FRAME.png)", "none")
    written = []
    for frame in frames:
        written.append(out / "drivestudio" / frame)
        labels = write_kitti_layout(kitti, frame, written[-1])
        gt = cv2.imread(str(kitti / "image_2" / f"{frame}.png"))
        fx = _calib(kitti / "calib" / f"{frame}.txt")["P2"][0]
        depth = float(np.median(labels["z"])) if len(labels) else 20.0  # rectified camera z, m
        for method, sigma in STAND_IN_SIGMAS.items():
            (out / f"renders-{method}" / frame).mkdir(parents=True, exist_ok=True)
            for i, y in enumerate(sorted(OFFSETS)):
                cv2.imwrite(str(out / f"renders-{method}" / frame / f"{i:05d}.png"),
                            stand_in(gt, sigma=sigma, shift_px=fx * y / depth))
    return written


def main(argv=None) -> int:
    """``python -m nvrq.examples.kitti_drivestudio KITTI OUT``; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0, or 2 with one line on a bad input.
    """
    from data_schema.errors import InputError

    parser = argparse.ArgumentParser(prog="python -m nvrq.examples.kitti_drivestudio",
                                     description="A small example drivestudio folder from KITTI object frames.")
    parser.add_argument("kitti", help="KITTI object folder, e.g. ../shared/realdata/kitti")
    parser.add_argument("out", help="example folder to write")
    args = parser.parse_args(argv)
    try:
        written = make_example(args.kitti, args.out)
    except InputError as exc:  # one line, as every command (a library module: no CLI layer import)
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {len(written)} drivestudio folders under {Path(args.out) / 'drivestudio'} and stand-in "
          f"renders of methods {', '.join(STAND_IN_SIGMAS)}")
    return 0

if __name__ == "__main__":
    sys.exit(main())
