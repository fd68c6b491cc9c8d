"""What a rater page shows of an item, read once per server process: its crops, its kind
and its crop side.

Every displayed crop carries a salt (an HMAC of the study id, the item, its position on the
page and the rater, keyed by the study's admin token) embedded as metadata, so its bytes,
hence the URL the page serves it under, differ between items, positions and raters while
the pixels stay the crop's. A study never changes its crops (a rebuilt one has a new study
id and is refused by :meth:`annotate.study.Study.check_current` before anything is drawn),
so a server keeps each crop file's bytes in memory after its first showing (one copy per
file, whatever the number of raters) and salts them per showing (an HMAC and a copy: a few
microseconds); the cache lives in this module, which a Streamlit rerun
does not re-execute, one per study folder and study id. So are the per-item facts the page
needs on every vote (kind, crop side), as plain dicts instead of DataFrame lookups.
"""

from __future__ import annotations

import hashlib
import hmac
import threading
import zlib

from annotate.study import Study, crop_path

__all__ = ["salted_image", "ItemDisplay", "item_display"]

_CACHES: dict[tuple[str, str], ItemDisplay] = {}
_LOCK = threading.Lock()


def salted_image(data: bytes, salt: bytes) -> bytes:
    """``data`` (JPEG or PNG bytes) with ``salt`` embedded as metadata; pixels unchanged.

    JPEG: a COM segment after SOI; PNG: a private ancillary ``prVt`` chunk after IHDR.
    Decoders ignore both, but the bytes (hence Streamlit's content-hash URL) differ per salt.

    Parameters
    ----------
    data : bytes
        A JPEG or PNG file.
    salt : bytes
        The metadata to embed.

    Returns
    -------
    bytes

    >>> import cv2, numpy as np
    >>> img = np.full((8, 8, 3), 90, np.uint8)
    >>> for ext in (".jpg", ".png"):
    ...     raw = cv2.imencode(ext, img)[1].tobytes()
    ...     a, b = salted_image(raw, b"a"), salted_image(raw, b"b")
    ...     dec = cv2.imdecode(np.frombuffer(a, np.uint8), cv2.IMREAD_COLOR)
    ...     print(a != b, np.array_equal(dec, cv2.imdecode(np.frombuffer(raw, np.uint8), 1)))
    True True
    True True
    """
    if data[:2] == b"\xff\xd8":
        return data[:2] + b"\xff\xfe" + (len(salt) + 2).to_bytes(2, "big") + salt + data[2:]
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        end = 8 + 12 + int.from_bytes(data[8:12], "big")  # signature + IHDR chunk
        chunk = b"prVt" + salt
        return (data[:end] + len(salt).to_bytes(4, "big") + chunk
                + zlib.crc32(chunk).to_bytes(4, "big") + data[end:])
    raise ValueError("crop: expected JPEG or PNG bytes")


class ItemDisplay:
    """One study's items as the page shows them.

    Parameters
    ----------
    study : Study
        An open study.

    Attributes
    ----------
    kind : dict
        Item key -> ``items.csv`` kind (training, test, gold, repeat).
    crop_side : dict
        Item key -> the object's square side in camera pixels (empty for a study without
        the column: no scale line).
    """

    def __init__(self, study: Study):
        self.study = study
        self._secret = study.admin_token().encode()
        self._crops: dict[tuple[str, str, str], bytes] = {}
        self.kind = study.items["kind"].to_dict()
        self.crop_side = study.items["crop_side"].to_dict() if "crop_side" in study.items else {}

    def crops(self, key: str, slots, rater: str = "") -> tuple[bytes, ...]:
        """The crops of item ``key`` for ``slots``, ``((position, file column), ...)``, as
        ``rater`` is shown them.

        Parameters
        ----------
        key : str
            The item key.
        slots : sequence of (str, str)
            (position on the page, ``items.csv`` file column) of each crop.
        rater : str, optional
            The rater they are shown to: the salt includes it, so two raters never get the
            same bytes (counting which images more than ``votes_per_item``
            identities saw found every gold item).

        Returns
        -------
        tuple of bytes
            The salted JPEG/PNG bytes, in ``slots`` order.

        Raises what reading the crop raises (InputError, OSError, KeyError, ValueError); a
        crop that fails is not kept, so it fails again on its next showing.
        """
        out = []
        study_id = self.study.manifest.study_id
        for side, col in slots:
            data = self._crops.get((key, col))
            if data is None:
                data = crop_path(self.study.root, self.study.items.at[key, col]).read_bytes()
                self._crops[(key, col)] = data
            salt = hmac.new(self._secret, f"{study_id}|{key}|{side}|{rater}".encode(),
                            hashlib.sha256).hexdigest()[:24].encode()
            out.append(salted_image(data, salt))
        return tuple(out)


def item_display(study: Study) -> ItemDisplay:
    """The process's :class:`ItemDisplay` of ``study`` (one per folder and study id).

    Parameters
    ----------
    study : Study
        An open study; its folder and ``study_id`` key the cache.

    Returns
    -------
    ItemDisplay
        Shared by every session of this study in the process (crops read once).
    """
    ident = (str(study.root), str(study.manifest.study_id))
    found = _CACHES.get(ident)
    if found is None:
        with _LOCK:
            found = _CACHES.setdefault(ident, ItemDisplay(study))
    return found
