"""NTA-IoU matching speed: the vectorised core (:func:`nvrq.proxies.nta_iou.evaluate`) against a
straightforward per-box loop, and the time for 1M detections over 100k images.

Data: per image (1920x1080) 8 projected boxes (vehicles and people, overlapping lanes) and 10
detections: the boxes jittered by a few pixels, 10% missed, false positives, and a few
duplicates (so the one-to-one ``nvrq`` protocol needs the Hungarian step on some images). The
loop is timed on ``--loop-images`` images and the vectorised core on the same images, for the
ratio; then the core alone on ``--images`` images. Run: ``python benchmarks/bench_nta.py``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nvrq.proxies.nta_iou import _iou, evaluate, get_protocol

LABELS = np.array(["automobile", "person"], dtype=object)
COCO = np.array(["car", "person"], dtype=object)


def make_data(n_images: int, *, boxes_per_image: int = 8, dets_per_image: int = 10, seed: int = 0):
    rng = np.random.default_rng(seed)
    nb = n_images * boxes_per_image
    img = np.repeat(np.arange(n_images), boxes_per_image)
    xy = rng.uniform([0, 300], [1800, 900], (nb, 2))
    wh = rng.uniform([30, 30], [300, 200], (nb, 2))
    boxes = np.concatenate([xy, xy + wh], axis=1)
    cls = rng.integers(0, 2, nb)
    n_extra = dets_per_image - boxes_per_image
    keep = rng.random(nb) > 0.1
    det = boxes[keep] + rng.normal(0, 4, (int(keep.sum()), 4))
    det[:, 2:] = np.maximum(det[:, 2:], det[:, :2] + 1)
    d_img, d_cls = img[keep], cls[keep]
    m_extra = n_images * n_extra + (nb - int(keep.sum()))
    e_img = rng.integers(0, n_images, m_extra)
    src = rng.integers(0, nb, m_extra)  # duplicates near some box of that image, or anywhere
    e_box = np.where(rng.random((m_extra, 1)) < 0.5, boxes[(e_img * boxes_per_image) + src % boxes_per_image]
                     + rng.normal(0, 15, (m_extra, 4)), np.concatenate([xy[src], xy[src] + 40], axis=1))
    e_box[:, 2:] = np.maximum(e_box[:, 2:], e_box[:, :2] + 1)
    dets = {"image": np.concatenate([d_img, e_img]), "boxes": np.concatenate([det, e_box]),
            "scores": rng.uniform(0.3, 1.0, len(d_img) + m_extra),
            "labels": COCO[np.concatenate([d_cls, rng.integers(0, 2, m_extra)])]}
    return {"image": img, "boxes": boxes, "labels": LABELS[cls]}, dets


def loop_nvrq(boxes: dict, dets: dict, size=(1920, 1080)) -> np.ndarray:
    """The straightforward way: per image, per box, per detection, then Hungarian per image."""
    from scipy.optimize import linear_sum_assignment

    allowed = {"automobile": {"car", "truck", "bus"}, "person": {"person"}}
    out = np.zeros(len(boxes["image"]))
    for im in np.unique(boxes["image"]):
        bi = np.flatnonzero(boxes["image"] == im)
        di = [j for j in np.flatnonzero(dets["image"] == im) if dets["scores"][j] > 0.5]
        m = np.zeros((len(bi), len(di)))
        for a, i in enumerate(bi):
            b = np.clip(boxes["boxes"][i], 0, [size[0], size[1], size[0], size[1]])
            for c, j in enumerate(di):
                if dets["labels"][j] in allowed[boxes["labels"][i]]:
                    m[a, c] = _iou(b[None], dets["boxes"][j][None])[0]
        if m.size:
            r, c = linear_sum_assignment(m, maximize=True)
            out[bi[r]] = m[r, c]
    return out


def run(boxes, dets, protocol: str) -> tuple[float, np.ndarray]:
    sizes = np.broadcast_to(np.array([1920.0, 1080.0]), (len(boxes["image"]), 2))
    t0 = time.perf_counter()
    res = evaluate(boxes, dets, sizes, get_protocol(protocol))
    return time.perf_counter() - t0, res["iou"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--images", type=int, default=100_000, help="images of the big run (default 100000)")
    ap.add_argument("--loop-images", type=int, default=2000, help="images of the loop comparison (default 2000)")
    args = ap.parse_args()
    small = make_data(args.loop_images, seed=1)
    t0 = time.perf_counter()
    ref = loop_nvrq(*small)
    t_loop = time.perf_counter() - t0
    t_vec, got = run(*small, "nvrq")
    assert np.allclose(np.sort(got), np.sort(ref), atol=1e-12), "vectorised and loop disagree"
    print(f"{args.loop_images} images, {len(small[1]['image'])} detections: loop {t_loop:.2f} s, "
          f"vectorised {t_vec:.3f} s, speed-up (vectorised / loop) {t_loop / t_vec:.0f}x")
    big = make_data(args.images, seed=2)
    for protocol in ("nvrq", "recondreamer"):
        t, iou = run(*big, protocol)
        print(f"{protocol}: {len(big[1]['image'])} detections over {args.images} images, "
              f"{len(big[0]['image'])} boxes: {t:.1f} s (target < 60 s), NTA-IoU {iou.mean():.4f}")


if __name__ == "__main__":
    main()
