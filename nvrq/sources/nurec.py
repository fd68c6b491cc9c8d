"""Import a NVIDIA NuRec scene archive (``.usdz``, a zip) as a scene folder (docs/FORMATS.md §2).

Read from the archive (members found by file name, at any depth):

``rig_trajectories.json``
    ``T_world_base`` (4x4, world -> global base frame; checked, not applied: the scene keeps
    NCore's local world), ``world_to_nre`` (``{"matrix": 4x4}`` or a bare 4x4),
    ``camera_calibrations`` (``"<camera>@<sequence>"`` -> ``logical_sensor_name``,
    ``T_sensor_rig``, ``camera_model {type: ftheta, parameters}``) and
    ``rig_trajectories[]`` (``sequence_id``, ``T_rig_worlds``, ``T_rig_world_timestamps_us``,
    ``cameras_frame_timestamps_us``: unique camera id -> ``[[start, end], ...]``).
``sequence_tracks.json``
    ``tracks_data`` (``tracks_id``, ``tracks_label_class``, ``tracks_flags``,
    ``tracks_timestamps_us``, ``tracks_poses`` ``[x, y, z, qx, qy, qz, qw]``) and
    ``cuboidtracks_data.cuboids_dims`` ``[l, w, h]``, either at the top level or under one
    key per sequence (the importer takes the chosen sequence's, else the only one).

Frames: a camera frame is stamped with its **end** time (``cameras_frame_timestamps_us[i][1]``);
frames outside the rig trajectory are left out (never extrapolated).

Frames (convention): ``T_rig_worlds`` map rig -> world (NCore's local world).
``world_to_nre`` maps world points into the reconstruction's (NRE) frame,
``p_nre = world_to_nre @ p_world``, and the track poses are given in the NRE frame, so the
importer writes ``T_box_world = inv(world_to_nre) @ T_box_nre``. ``world_to_nre`` may carry
a uniform scale ``s`` (``R = s * Q``); box dimensions are then divided by ``s``.
f-theta ``parameters`` become the scene.json model unchanged (same names; the principal point is
in the same pixel-centre convention).

``images.csv`` lists the GT image and one render per ``--offsets`` value (or per
``--perturb`` view, with the perturbation columns) for every kept frame, at :func:`nvrq.render_plans.default_image_path`; the files do not exist yet (the
user's renderer writes them, see ``nvrq render-plan``).
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from data_schema.errors import InputError
from data_schema.perturbation import views_from
from data_schema.scene import CAMERA_MODEL_SCHEMA, CameraCalib, Track
from data_schema.scene_writer import NewScene, SceneFrame
from nvrq.geometry.cameras import camera_from_model
from nvrq.geometry.poses import matrix_to_pose7, pose7_to_matrix
from nvrq.render_plans import default_image_path
from nvrq.sources.base import ImportedScene, write_imported

__all__ = ["import_nurec", "read_nurec", "read_archive_json", "NurecImporter", "IMPORTER"]


def read_archive_json(archive: Path, name: str) -> tuple[dict, str]:
    """Parse the member called ``name`` (at any depth) of the zip ``archive``; (doc, member path).

    Parameters
    ----------
    archive : pathlib.Path
        The NuRec ``.usdz`` archive (a zip file).
    name : str
        The member's file name; the shallowest match is read.

    Returns
    -------
    doc : dict
        The parsed JSON document.
    member : str
        The member's path inside the archive.
    """
    try:
        with zipfile.ZipFile(archive) as zf:
            members = [m for m in zf.namelist() if m.rsplit("/", 1)[-1] == name]
            if not members:
                raise InputError(archive, name, f"an archive member named {name}", "missing")
            member = sorted(members, key=lambda m: (m.count("/"), m))[0]
            raw = zf.read(member)
    except FileNotFoundError:
        raise InputError(archive, None, "an existing NuRec .usdz archive", "no such file") from None
    except zipfile.BadZipFile:
        raise InputError(
            archive, None, "a NuRec .usdz archive (a zip file)", "not a zip file"
        ) from None
    try:
        return json.loads(raw), member
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(
            f"{archive}:{member}", None, "valid JSON", f"{type(exc).__name__}: {exc}"
        ) from None


def _get(obj, key, where, prefix):
    if not isinstance(obj, dict):
        raise InputError(where, prefix or None, "a JSON object", type(obj).__name__)
    if key not in obj:
        raise InputError(where, f"{prefix}.{key}" if prefix else key, "this field", "missing")
    return obj[key]


def _matrix(value, where, fld, *, n=None, rigid=True, scale_ok=False) -> tuple[np.ndarray, float]:
    """4x4 matrix (or ``(n, 4, 4)``); returns (matrix, uniform scale)."""
    try:
        M = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(where, fld, "4x4 matrices of numbers", repr(value)[:80]) from None
    shape = (4, 4) if n is None else (n, 4, 4)
    if M.shape != shape or not np.isfinite(M).all():
        raise InputError(where, fld, f"a finite array of shape {shape}", f"shape {M.shape}")
    R = M[..., :3, :3]
    det = np.linalg.det(R)
    scale = np.cbrt(det) if scale_ok else np.ones_like(det)
    if rigid:
        Q = R / np.asarray(scale)[..., None, None]
        err = np.abs(Q @ np.swapaxes(Q, -1, -2) - np.eye(3)).max() if Q.size else 0.0
        bottom = np.abs(M[..., 3, :] - [0, 0, 0, 1]).max() if M.size else 0.0
        if err > 1e-5 or bottom > 1e-9 or np.any(det <= 0):
            what = "rotation (times a uniform scale)" if scale_ok else "rotation"
            raise InputError(
                where,
                fld,
                f"rigid 4x4 transforms: a {what}, bottom row 0 0 0 1",
                f"orthonormality error {err:.2g}",
            )
    return M, float(np.ravel(scale)[0]) if np.size(scale) else 1.0


def _timestamps(value, where, fld) -> np.ndarray:
    arr = np.asarray(value)
    if arr.ndim != 1 or len(arr) == 0 or not np.issubdtype(arr.dtype, np.integer):
        raise InputError(where, fld, "a non-empty list of integer microseconds", repr(value)[:80])
    arr = arr.astype(np.int64)
    if np.any(np.diff(arr) <= 0):
        raise InputError(
            where, fld, "strictly increasing timestamps", "unsorted or repeated values"
        )
    return arr


def _spec_ftheta(model, where, fld) -> dict:
    mtype = _get(model, "type", where, fld)
    if mtype != "ftheta":
        raise InputError(where, f"{fld}.type", "ftheta", repr(mtype))
    params = _get(model, "parameters", where, fld)
    if not isinstance(params, dict):
        raise InputError(where, f"{fld}.parameters", "a JSON object", type(params).__name__)
    spec = {"type": "ftheta"}
    for k in CAMERA_MODEL_SCHEMA["ftheta"]:
        if k in params:
            spec[k] = params[k]
    ref = spec.get("reference_poly")
    if isinstance(ref, str) and "." in ref:  # e.g. "PolynomialType.PIXELDIST_TO_ANGLE"
        spec["reference_poly"] = ref.rsplit(".", 1)[-1]
    if isinstance(spec.get("resolution"), list):
        spec["resolution"] = [int(v) for v in spec["resolution"]]
    camera_from_model(spec, where=where, field_prefix=f"{fld}.parameters.")
    return spec


def _tracks_block(doc, sequence_id, where):
    if isinstance(doc, dict) and "tracks_data" in doc:
        return doc
    if isinstance(doc, dict) and doc:
        if sequence_id in doc:
            return doc[sequence_id]
        if len(doc) == 1:
            return next(iter(doc.values()))
        raise InputError(
            where,
            None,
            f"tracks for sequence {sequence_id!r} (or a single sequence)",
            f"sequences {', '.join(map(str, doc))}",
        )
    raise InputError(
        where, None, "an object with tracks_data and cuboidtracks_data", type(doc).__name__
    )


def _read_tracks(doc, sequence_id, where, nre_to_world, scale) -> list[Track]:
    block = _tracks_block(doc, sequence_id, where)
    td = _get(block, "tracks_data", where, "")
    cd = _get(block, "cuboidtracks_data", where, "")
    ids = _get(td, "tracks_id", where, "tracks_data")
    fields = {
        k: _get(td, k, where, "tracks_data")
        for k in ("tracks_label_class", "tracks_flags", "tracks_timestamps_us", "tracks_poses")
    }
    fields["cuboids_dims"] = _get(cd, "cuboids_dims", where, "cuboidtracks_data")
    for k, v in fields.items():
        if not isinstance(v, list) or len(v) != len(ids):
            got = len(v) if isinstance(v, list) else type(v).__name__
            raise InputError(where, k, f"a list with one entry per track ({len(ids)})", got)
    tracks = []
    for i, tid in enumerate(ids):
        fld = f"tracks_data[{i}] ({tid})"
        ts = _timestamps(fields["tracks_timestamps_us"][i], where, f"{fld}.tracks_timestamps_us")
        poses = np.asarray(fields["tracks_poses"][i], dtype=np.float64)
        if poses.shape != (len(ts), 7) or not np.isfinite(poses).all():
            raise InputError(
                where,
                f"{fld}.tracks_poses",
                f"{len(ts)} poses [x, y, z, qx, qy, qz, qw]",
                f"shape {poses.shape}",
            )
        if np.any(np.linalg.norm(poses[:, 3:], axis=1) < 1e-6):
            raise InputError(where, f"{fld}.tracks_poses", "unit quaternions", "a zero quaternion")
        dims = np.asarray(fields["cuboids_dims"][i], dtype=np.float64)
        if dims.ndim == 2 and dims.shape[1] == 3:  # one box per timestamp: take the median
            dims = np.median(dims, axis=0)
        if dims.shape != (3,) or not np.all(np.isfinite(dims)) or np.any(dims <= 0):
            raise InputError(
                where, f"cuboidtracks_data.cuboids_dims[{i}]", "[l, w, h] > 0", dims.tolist()
            )
        T_world = nre_to_world @ pose7_to_matrix(poses)
        T_world[:, :3, :3] *= scale  # nre_to_world scales by 1/s; boxes keep a pure rotation
        tracks.append(Track(str(tid), str(fields["tracks_label_class"][i]), dims / scale, ts,
                            matrix_to_pose7(T_world)))
    return tracks


def _world_to_nre(rig: dict, where: str) -> tuple[np.ndarray, float]:
    """``(nre_to_world (4, 4), scale)`` from ``world_to_nre`` (``T_world_base`` only checked)."""
    if "T_world_base" in rig:
        _matrix(rig["T_world_base"], where, "T_world_base", rigid=False)
    w2n = _get(rig, "world_to_nre", where, "")
    w2n_fld = "world_to_nre.matrix" if isinstance(w2n, dict) else "world_to_nre"
    W, scale = _matrix(
        w2n["matrix"] if isinstance(w2n, dict) and "matrix" in w2n else w2n,
        where,
        w2n_fld,
        scale_ok=True,
    )
    return np.linalg.inv(W), scale


def _pick_trajectory(rig: dict, where: str, sequence: str | None):
    """The chosen rig trajectory: ``(seq_ids, k, traj, field, rig_ts, T_rig_world)``."""
    trajs = _get(rig, "rig_trajectories", where, "")
    if not isinstance(trajs, list) or not trajs:
        raise InputError(where, "rig_trajectories", "a non-empty list", repr(trajs)[:60])
    seq_ids = [
        str(t.get("sequence_id", i)) if isinstance(t, dict) else str(i) for i, t in enumerate(trajs)
    ]
    if sequence is None:
        k = 0
    elif sequence in seq_ids:
        k = seq_ids.index(sequence)
    else:
        raise InputError(param="sequence", expected=f"one of {', '.join(seq_ids)}", got=sequence)
    traj, tfld = trajs[k], f"rig_trajectories[{k}]"
    rig_ts = _timestamps(
        _get(traj, "T_rig_world_timestamps_us", where, tfld),
        where,
        f"{tfld}.T_rig_world_timestamps_us",
    )
    T_rw, _ = _matrix(
        _get(traj, "T_rig_worlds", where, tfld), where, f"{tfld}.T_rig_worlds", n=len(rig_ts)
    )
    return seq_ids, k, traj, tfld, rig_ts, T_rw


def _camera_frames(frames: dict, uid: str, where: str, tfld: str, rig_ts: np.ndarray) -> np.ndarray:
    """End timestamps ``(N,)`` of ``uid``'s frames inside the rig trajectory."""
    fr = np.asarray(frames[uid])
    if fr.ndim != 2 or fr.shape[1] != 2 or not np.issubdtype(fr.dtype, np.integer):
        raise InputError(
            where,
            f"{tfld}.cameras_frame_timestamps_us.{uid}",
            "a list of [start_us, end_us] integer pairs",
            repr(frames[uid])[:60],
        )
    end = fr[:, 1].astype(np.int64)
    return end[(end >= rig_ts[0]) & (end <= rig_ts[-1])]


def _cameras_and_frames(rig: dict, traj: dict, where: str, tfld: str, rig_ts: np.ndarray) -> tuple[dict, list]:
    """The cameras of the trajectory's sequence and their GT frames (:class:`SceneFrame`, listed
    at :func:`default_image_path`, no file: the user copies the camera frames there)."""
    frames = _get(traj, "cameras_frame_timestamps_us", where, tfld)
    calibs = _get(rig, "camera_calibrations", where, "")
    if not isinstance(calibs, dict) or not isinstance(frames, dict):
        raise InputError(
            where,
            "camera_calibrations",
            "an object keyed by '<camera>@<sequence>'",
            type(calibs).__name__,
        )
    cameras, frames_out = {}, []
    for uid, cal in calibs.items():
        if uid not in frames:
            continue  # a camera of another sequence
        cfld = f"camera_calibrations.{uid}"
        name = (
            str(cal.get("logical_sensor_name") or uid.split("@", 1)[0])
            if isinstance(cal, dict)
            else uid
        )
        T_sr, _ = _matrix(_get(cal, "T_sensor_rig", where, cfld), where, f"{cfld}.T_sensor_rig")
        model = _spec_ftheta(_get(cal, "camera_model", where, cfld), where, f"{cfld}.camera_model")
        cameras[name] = CameraCalib(name, T_sr, model)
        frames_out += [SceneFrame(name, int(t), default_image_path(name, t, "gt"))
                       for t in _camera_frames(frames, uid, where, tfld, rig_ts)]
    if not cameras:
        raise InputError(
            where,
            f"{tfld}.cameras_frame_timestamps_us",
            "frame timestamps for at least one calibrated camera",
            "none",
        )
    return cameras, frames_out


class NurecImporter:
    """``nvrq import nurec ARCHIVE OUT`` (:class:`nvrq.sources.base.Importer`)."""

    def read(self, path, **options) -> ImportedScene:
        """Read the archive ``path`` (:func:`read_nurec`).

        Parameters
        ----------
        path : path
            The ``.usdz`` archive.
        **options
            :func:`read_nurec`'s ``offsets``, ``perturbations``, ``sequence``, ``clip_attributes``.

        Returns
        -------
        ImportedScene
            The scene and its views.
        """
        return read_nurec(path, **options)


#: The importer of ``nvrq import nurec``.
IMPORTER = NurecImporter()


def read_nurec(archive: str | Path, *, offsets=(-3, -2, -1, 0, 1, 2, 3), perturbations=None,
               sequence: str | None = None, clip_attributes=None) -> ImportedScene:
    """Read and check the NuRec ``archive`` (module docstring); nothing written.

    Parameters
    ----------
    archive : path
        The ``.usdz`` archive.
    offsets : sequence of float
        Lateral render offsets (metres), used when ``perturbations`` is None.
    perturbations : numpy.ndarray, (K, 6), optional
        6-DoF views (``dx, dy, dz`` metres, ``roll, pitch, yaw`` degrees, rig frame).
    sequence : str, optional
        The rig trajectory's ``sequence_id`` (default: the first).
    clip_attributes : nvrq.clip_attributes.ClipAttributes, optional
        Its row for this clip becomes the scene's ``attributes`` (default: none).

    Returns
    -------
    ImportedScene
        The scene (GT frames listed, no files) and the views.
    """
    archive = Path(archive)
    views = views_from(offsets, perturbations)
    rig, rig_member = read_archive_json(archive, "rig_trajectories.json")
    where = f"{archive}:{rig_member}"
    nre_to_world, scale = _world_to_nre(rig, where)
    seq_ids, k, traj, tfld, rig_ts, T_rw = _pick_trajectory(rig, where, sequence)
    cameras, frames = _cameras_and_frames(rig, traj, where, tfld, rig_ts)
    tracks_doc, tr_member = read_archive_json(archive, "sequence_tracks.json")
    tracks = _read_tracks(tracks_doc, seq_ids[k], f"{archive}:{tr_member}", nre_to_world, scale)
    attributes = {} if clip_attributes is None else clip_attributes.require(seq_ids[k])
    scene = NewScene(seq_ids[k], cameras, rig_ts, T_rw, tracks, frames, attributes)
    return ImportedScene(scene, views)


def import_nurec(
    archive: str | Path,
    out: str | Path,
    *,
    offsets=(-3, -2, -1, 0, 1, 2, 3),
    perturbations=None,
    sequence: str | None = None,
    clip_attributes=None,
) -> Path:
    """Convert the NuRec ``archive`` into the scene folder ``out`` (:func:`read_nurec`, then the one
    writer: whole and atomically).

    Parameters
    ----------
    archive : path
        The ``.usdz`` archive.
    out : path
        The scene folder.
    offsets, perturbations, sequence, clip_attributes
        As :func:`read_nurec`.

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    imported = read_nurec(archive, offsets=offsets, perturbations=perturbations, sequence=sequence,
                          clip_attributes=clip_attributes)
    return write_imported(imported, out)
