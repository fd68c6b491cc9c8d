"""Per-dataset facts of drivestudio's processed scenes (used by :mod:`nvrq.sources.drivestudio`).

Camera names and counts: ``DATASETS_CONFIG`` of drivestudio ``datasets/dataset_meta.py``; frame
rates: the preprocessors (Waymo, PandaSet, Argoverse 2, nuPlan and KITTI-raw at 10 Hz, nuScenes'
annotated keyframes at 2 Hz, ``nuscenes_preprocess.py``); class names: each preprocessor's
``*_DYNAMIC_CLASSES``; the class table is docs/FORMATS.md §13's.
"""

from __future__ import annotations

from nvrq.sources.kitti import KITTI_CLASS_MAP, R_SENSOR_RIG

__all__ = ["DATASETS", "PER_FRAME", "CAMERA_NAMES", "DEFAULT_FPS", "OPENCV_TO_FLU", "CLASS_MAPS", "map_class"]

#: drivestudio's dataset folder names (``--dataset``).
DATASETS = ("waymo", "nuscenes", "pandaset", "argoverse", "nuplan", "kitti")
#: Datasets with per-frame camera -> world extrinsics ``extrinsics/{t:03d}_{cam}.txt``.
PER_FRAME = ("nuscenes", "pandaset")
#: Camera names by index (drivestudio ``datasets/dataset_meta.py``).
CAMERA_NAMES = {
    "waymo": ("front_camera", "front_left_camera", "front_right_camera", "left_camera", "right_camera"),
    "nuscenes": ("CAM_FRONT", "CAM_FRONT_LEFT", "CAM_FRONT_RIGHT", "CAM_BACK_LEFT", "CAM_BACK_RIGHT", "CAM_BACK"),
    "pandaset": ("front_camera", "front_left_camera", "front_right_camera", "left_camera", "right_camera",
                 "back_camera"),
    "argoverse": ("ring_front_center", "ring_front_left", "ring_front_right", "ring_side_left", "ring_side_right",
                  "ring_rear_left", "ring_rear_right"),
    "nuplan": ("CAM_F0", "CAM_L0", "CAM_R0", "CAM_L1", "CAM_R1", "CAM_L2", "CAM_R2", "CAM_B0"),
    "kitti": ("CAM_LEFT", "CAM_RIGHT"),
}
#: Frame rate of each dataset's processed frames (Hz); nuScenes: its 2 Hz keyframes.
DEFAULT_FPS = {"waymo": 10.0, "nuscenes": 2.0, "pandaset": 10.0, "argoverse": 10.0, "nuplan": 10.0, "kitti": 10.0}
#: OpenCV camera axes (x right, y down, z forward) -> x forward, y left, z up: Waymo's
#: ``OPENCV2DATASET`` rotation, the same matrix as the KITTI importer's camera -> rig rotation.
OPENCV_TO_FLU = R_SENSOR_RIG
#: ``class_name`` -> our ``label_class`` per dataset (docs/FORMATS.md §13); any other name is
#: kept; nuScenes ``human.pedestrian.*`` -> ``person`` (:func:`map_class`).
CLASS_MAPS = {
    "waymo": {"Vehicle": "automobile", "Pedestrian": "person", "Cyclist": "rider"},
    "nuscenes": {"vehicle.car": "automobile", "vehicle.emergency.police": "automobile",
                 "vehicle.bus.bendy": "bus", "vehicle.bus.rigid": "bus",
                 "vehicle.truck": "heavy_truck", "vehicle.trailer": "heavy_truck"},
    "pandaset": {"Car": "automobile", "Pickup Truck": "automobile", "Bus": "bus",
                 "Medium-sized Truck": "heavy_truck", "Semi-truck": "heavy_truck",
                 "Pedestrian": "person", "Pedestrian with Object": "person"},
    "argoverse": {"REGULAR_VEHICLE": "automobile", "BUS": "bus", "ARTICULATED_BUS": "bus", "SCHOOL_BUS": "bus",
                  "BOX_TRUCK": "heavy_truck", "TRUCK": "heavy_truck", "TRUCK_CAB": "heavy_truck",
                  "VEHICULAR_TRAILER": "heavy_truck", "PEDESTRIAN": "person", "OFFICIAL_SIGNALER": "person",
                  "BICYCLIST": "rider", "MOTORCYCLIST": "rider", "WHEELED_RIDER": "rider"},
    "nuplan": {"vehicle": "automobile", "pedestrian": "person"},
    "kitti": dict(KITTI_CLASS_MAP),  # the one KITTI table (``nvrq import kitti``)
}


def map_class(dataset: str, class_name: str) -> str:
    """Our ``label_class`` of a drivestudio ``class_name`` (:data:`CLASS_MAPS`; others kept).

    Parameters
    ----------
    dataset : str
        The source dataset (a key of :data:`CLASS_MAPS`).
    class_name : str
        The dataset's class name.

    Returns
    -------
    str
        The mapped class, or ``class_name`` when it has no mapping.

    >>> map_class("nuscenes", "human.pedestrian.adult"), map_class("waymo", "Cyclist"), map_class("waymo", "Sign")
    ('person', 'rider', 'Sign')
    """
    if dataset == "nuscenes" and class_name.startswith("human.pedestrian."):
        return "person"
    return CLASS_MAPS.get(dataset, {}).get(class_name, class_name)
