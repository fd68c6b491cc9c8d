"""The synthetic world of one clip: road, ego trajectory, traffic and roadside scenery.

Layer: nvrq core, synth (synthetic scenes).

Everything is drawn from one ``numpy.random.Generator``, so a seed fixes the clip.

Convention: world frame z up, road on the plane z = 0. The road centreline starts at the
origin heading +x and bends with constant signed curvature ``kappa`` (1/m, left > 0). A
road coordinate ``(s, d)`` is the arc length along the centreline and the signed lateral
distance (left > 0); traffic drives on the right. Box poses are centres, so an object of
height h stands at z = h / 2.

>>> road = Road(kappa=1 / 400, lanes_per_dir=1, lane_w=3.5, median_w=0.0, shoulder_w=2.0, road_type="rural")
>>> x, y, psi = road.to_world(np.array([0.0, 100.0]), np.array([-1.75, 3.0]))
>>> [round(float(v), 6) for v in (x[0], y[0], psi[1])]   # start: (0, d); heading s * kappa
[0.0, -1.75, 0.25]
>>> [np.round(v, 9).tolist() for v in road.to_road(x, y)]  # inverse
[[0.0, 100.0], [-1.75, 3.0]]
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from nvrq.synth.textures import CAR_COLOURS

__all__ = ["Road", "Actor", "World", "SIZES", "ROAD_TYPES", "LIGHTINGS", "CLASSES"]

ROAD_TYPES = ("urban", "highway", "residential", "rural")
LIGHTINGS = ("daytime", "nighttime")
CLASSES = ("automobile", "bus", "heavy_truck", "person", "rider")
#: (low, high) ranges of [length, width, height] in metres per class.
SIZES = {
    "automobile": ((3.9, 1.7, 1.4), (5.0, 2.0, 1.75)),
    "bus": ((11.0, 2.5, 3.0), (13.0, 2.55, 3.4)),
    "heavy_truck": ((12.0, 2.45, 3.6), (16.5, 2.55, 4.0)),
    "person": ((0.5, 0.55, 1.55), (0.7, 0.75, 1.92)),
    "rider": ((1.7, 0.6, 1.6), (1.9, 0.75, 1.85)),
}


@dataclass
class Road:
    """A constant-curvature road; lanes of width ``lane_w`` each side of a median.

    Attributes
    ----------
    kappa : float, 1/m
        Signed curvature of the centreline (left > 0).
    lanes_per_dir : int
        Lanes in each direction.
    lane_w, median_w, shoulder_w : float, metres
        Widths of a lane, the median and the shoulder.
    road_type : str
        One of :data:`ROAD_TYPES`.
    """

    kappa: float
    lanes_per_dir: int
    lane_w: float
    median_w: float
    shoulder_w: float  # parking strip / hard shoulder width on each side
    road_type: str

    @property
    def half_width(self) -> float:
        """Lateral distance from the centreline to the road edge (kerb), metres."""
        return self.median_w / 2 + self.lanes_per_dir * self.lane_w + self.shoulder_w

    def lane_d(self, k: int, *, oncoming: bool = False) -> float:
        """Centre of lane ``k`` (0 next to the median) on the right (or left if ``oncoming``)."""
        d = self.median_w / 2 + (k + 0.5) * self.lane_w
        return d if oncoming else -d

    def to_world(self, s: np.ndarray, d: np.ndarray):
        """Road coordinates ``(s, d): (N,)`` -> world ``(x, y, heading): (N,)``."""
        s, d = np.asarray(s, float), np.asarray(d, float)
        psi = self.kappa * s
        if self.kappa == 0.0:
            return s.copy(), d.copy(), psi
        R = 1.0 / self.kappa
        x = (R - d) * np.sin(psi)
        y = R - (R - d) * np.cos(psi)
        return x, y, psi

    def to_road(self, x: np.ndarray, y: np.ndarray):
        """World ``(x, y)`` -> road ``(s, d)`` (inverse of :meth:`to_world`)."""
        x, y = np.asarray(x), np.asarray(y)
        if not np.issubdtype(x.dtype, np.floating):
            x, y = x.astype(float), y.astype(float)
        if self.kappa == 0.0:
            return x.copy(), y.copy()
        R = 1.0 / self.kappa
        sg = np.sign(R)
        psi = np.arctan2(sg * x, sg * (R - y))
        d = R - sg * np.hypot(x, R - y)
        return R * psi, d


@dataclass
class Actor:
    """One traffic participant: per-frame box-centre poses ``T_box_world: (F, 4, 4)``.

    ``present: (F,)`` marks the frames it is tracked and drawn. ``coverage`` in (0, 1] is
    the fraction of training views that saw it (low = breaks down early); ``profile``
    (6,) the relative weight of each artefact kind.

    Attributes
    ----------
    track_id : str
        Track id in ``scene.json``.
    label_class : str
        One of :data:`CLASSES`.
    dims : (3,) float64, metres
        Length, width, height.
    T_box_world : (F, 4, 4) float64
        Box-centre poses, box frame to world frame (metres).
    present : (F,) bool
        Frames where it is tracked and drawn.
    colour : tuple
        RGB body colour.
    coverage : float
        Fraction of training views that saw it, in (0, 1].
    profile : (6,) float64
        Relative weight of each artefact kind.
    behaviour : str
        E.g. ``'parked'``, ``'oncoming'``, ``'crossing'``, ``'same_direction'``.
    """

    track_id: str
    label_class: str
    dims: np.ndarray
    T_box_world: np.ndarray
    present: np.ndarray
    colour: tuple
    coverage: float
    profile: np.ndarray
    behaviour: str


@dataclass
class World:
    """A clip's world (see module docstring). Scenery items are plain dicts for the renderer.

    Attributes
    ----------
    road : Road
        The road.
    lighting : str
        One of :data:`LIGHTINGS`.
    timestamps_us : (F,) int64, microseconds
        Frame times.
    T_rig_world : (F, 4, 4) float64
        Ego rig poses, rig frame to world frame (metres).
    actors : list of Actor
        The traffic participants.
    buildings, billboards : list of dict
        Scenery for the renderer.
    crosswalks : list of float, metres
        Arc-length positions of the crosswalks.
    s_range : (float, float), metres
        Arc-length range the scenery covers.
    """

    road: Road
    lighting: str
    timestamps_us: np.ndarray
    T_rig_world: np.ndarray
    actors: list[Actor]
    buildings: list[dict] = field(default_factory=list)  # {'centre','dims','yaw','colour'}
    billboards: list[dict] = field(default_factory=list)  # {'base','kind','height'}
    crosswalks: list[float] = field(default_factory=list)  # s positions
    s_range: tuple[float, float] = (0.0, 0.0)


def _pose(x, y, z, yaw) -> np.ndarray:
    """(N,) arrays -> (N, 4, 4) poses yawed about z."""
    n = len(x)
    T = np.zeros((n, 4, 4))
    c, s = np.cos(yaw), np.sin(yaw)
    T[:, 0, 0], T[:, 0, 1], T[:, 1, 0], T[:, 1, 1] = c, -s, s, c
    T[:, 2, 2] = T[:, 3, 3] = 1.0
    T[:, 0, 3], T[:, 1, 3], T[:, 2, 3] = x, y, z
    return T


class _Builder:
    def __init__(self, rng, road, t, s_ego, d_ego, v_ego):
        self.rng, self.road, self.t = rng, road, t
        self.s_ego, self.d_ego, self.v_ego = s_ego, d_ego, v_ego
        self.actors: list[Actor] = []
        self.count = {c: 0 for c in CLASSES}

    def add(self, cls, s, d, heading_rel, behaviour):
        """``s, d, heading_rel``: (F,) arrays (or scalars) of the box centre in road coords."""
        rng = self.rng
        lo, hi = SIZES[cls]
        dims = rng.uniform(lo, hi)
        F = len(self.t)
        s = np.broadcast_to(np.asarray(s, float), (F,))
        d = np.broadcast_to(np.asarray(d, float), (F,))
        h_rel = np.broadcast_to(np.asarray(heading_rel, float), (F,))
        x, y, psi = self.road.to_world(s, d)
        T = _pose(x, y, np.full(F, dims[2] / 2), psi + h_rel)
        ex, ey, _ = self.road.to_world(self.s_ego, np.full(F, self.d_ego))
        dist = np.hypot(x - ex, y - ey)
        present = dist < 110.0
        if not present.any():
            return
        few_views = rng.random() < 0.25
        coverage = rng.uniform(0.08, 0.3) if few_views else rng.uniform(0.55, 1.0)
        profile = rng.dirichlet(np.full(6, 0.8))
        profile = 0.25 + 0.75 * profile / profile.max()
        colour = CAR_COLOURS[int(rng.integers(len(CAR_COLOURS)))]
        self.count[cls] += 1
        tid = f"{cls}-{self.count[cls]:03d}"
        self.actors.append(
            Actor(tid, cls, dims, T, present, colour, float(coverage), profile, behaviour)
        )


def _road(rng: np.random.Generator) -> tuple[Road, str, dict]:
    """Road type, lighting, curvature and lane layout: ``(road, lighting, config)``."""
    road_type = ROAD_TYPES[int(rng.integers(len(ROAD_TYPES)))]
    lighting = LIGHTINGS[int(rng.random() < 0.35)]
    kappa = 0.0 if rng.random() < 0.4 else float(rng.choice([-1, 1]) / rng.uniform(350, 900))
    cfg = {
        "urban": dict(lanes=2, median=0.0, shoulder=2.2, v=(6.0, 9.0)),
        "residential": dict(lanes=1, median=0.0, shoulder=2.2, v=(5.0, 8.0)),
        "rural": dict(lanes=1, median=0.0, shoulder=1.0, v=(8.0, 12.0)),
        "highway": dict(lanes=2, median=3.0, shoulder=2.5, v=(10.0, 15.0)),
    }[road_type]
    return Road(kappa, cfg["lanes"], 3.5, cfg["median"], cfg["shoulder"], road_type), lighting, cfg


def _featured(b: _Builder, lane_e: int) -> float:
    """One of each class close and central at some point of the clip; returns the person's
    crossing position ``s`` (a crosswalk in town)."""
    rng, road, t, s_ego, v_ego, d_ego = b.rng, b.road, b.t, b.s_ego, b.v_ego, b.d_ego
    T_clip = float(t[-1]) if len(t) > 1 else 0.1
    kerb = road.half_width
    tf = rng.uniform(0.35, 0.65) * T_clip
    vp = rng.uniform(1.2, 1.6)
    sp = s_ego[0] + v_ego * tf + rng.uniform(11.0, 14.0)
    d_cross = np.clip(d_ego + vp * (t - tf), -kerb - 1.5, kerb + 1.5)
    b.add("person", sp, d_cross, np.pi / 2, "crossing")
    vr = max(v_ego - rng.uniform(1.0, 2.5), 2.0)
    sr = s_ego[0] + 10.0 + (v_ego - vr) * tf + vr * t
    b.add("rider", sr, d_ego - 0.9, 0.0, "same_direction")
    big = ["bus", "heavy_truck"]
    rng.shuffle(big)
    b.add(big[0], s_ego + rng.uniform(24.0, 32.0) + 0.0 * t, d_ego, 0.0, "same_direction")
    t_pass = rng.uniform(0.55, 0.8) * T_clip
    vo = rng.uniform(0.7, 1.0) * v_ego
    s_o = s_ego[0] + v_ego * t_pass - vo * (t - t_pass)
    b.add(big[1], s_o, road.lane_d(0, oncoming=True), np.pi, "oncoming")
    if road.lanes_per_dir > 1:  # a car alongside in the neighbouring lane
        b.add("automobile", s_ego + rng.uniform(8.0, 14.0), road.lane_d(1 - min(lane_e, 1)), 0.0,
              "same_direction")
    else:  # an oncoming car passing early in the clip
        t_car = rng.uniform(0.2, 0.5) * T_clip
        s_car = s_ego[0] + v_ego * t_car - 0.8 * v_ego * (t - t_car) + 12.0
        b.add("automobile", s_car, road.lane_d(0, oncoming=True), np.pi, "oncoming")
    return float(sp)


def _traffic(b: _Builder, lane_e: int) -> None:
    """General traffic in both directions (the ego lane ahead kept clear)."""
    rng, road, t, s_ego, v_ego = b.rng, b.road, b.t, b.s_ego, b.v_ego
    n_same = rng.integers(3, 7)
    for _ in range(n_same):
        k = int(rng.integers(road.lanes_per_dir))
        cls = rng.choice(["automobile"] * 6 + ["bus", "heavy_truck"])
        v = v_ego + rng.uniform(-3.0, 3.0)
        s_start = s_ego[0] + rng.uniform(-30.0, 120.0)
        if k == lane_e and abs(s_start - s_ego[0]) < 45:
            continue  # keep the ego lane clear ahead of the featured vehicle
        b.add(str(cls), s_start + v * t, road.lane_d(k), 0.0, "same_direction")
    for _ in range(rng.integers(3, 8)):
        k = int(rng.integers(road.lanes_per_dir))
        cls = rng.choice(["automobile"] * 6 + ["bus", "heavy_truck"])
        v = rng.uniform(0.7, 1.2) * max(v_ego, 6.0)
        s_start = s_ego[0] + rng.uniform(20.0, 200.0)
        b.add(str(cls), s_start - v * t, road.lane_d(k, oncoming=True), np.pi, "oncoming")


def _town_roadside(b: _Builder, s0: float, s1: float) -> None:
    """Parked cars, pedestrians on the pavements and riders (urban and residential roads)."""
    rng, road, t, s_ego = b.rng, b.road, b.t, b.s_ego
    kerb = road.half_width
    for side in (-1, 1):
        s = s0 + rng.uniform(0, 8)
        while s < s1:
            if rng.random() < 0.7:
                cls = "automobile" if rng.random() < 0.92 else "heavy_truck"
                b.add(cls, s, side * (kerb - road.shoulder_w / 2), rng.choice([0.0, np.pi]), "parked")
            s += rng.uniform(6.0, 12.0)
    for _ in range(rng.integers(4, 10)):
        side = rng.choice([-1, 1])
        v = rng.uniform(0.9, 1.6) * rng.choice([-1, 1])
        s_start = s_ego[0] + rng.uniform(-10.0, 120.0)
        b.add("person", s_start + v * t, side * (kerb + 1.5 + rng.uniform(-0.5, 0.5)),
              0.0 if v > 0 else np.pi, "walking")
    for _ in range(rng.integers(1, 4)):
        v = rng.uniform(3.0, 6.0)
        b.add("rider", s_ego[0] + rng.uniform(5.0, 100.0) + v * t, -(kerb - road.shoulder_w / 2), 0.0,
              "same_direction")


def _open_roadside(b: _Builder) -> None:
    """A stopped car or two on the shoulder with people around (rural roads and highways)."""
    rng, road, s_ego = b.rng, b.road, b.s_ego
    kerb = road.half_width
    for _ in range(rng.integers(1, 3)):
        s = s_ego[0] + rng.uniform(40.0, 140.0)
        b.add("automobile", s, -(kerb - road.shoulder_w / 2), 0.0, "parked")
        b.add("person", s + rng.uniform(-3, 3), -(kerb + 0.6), rng.uniform(-np.pi, np.pi), "standing")


def build_world(rng: np.random.Generator, *, timestamps_us: np.ndarray) -> World:
    """Draw a clip's world for frames at ``timestamps_us: (F,)``: road, ego motion, featured
    participants, traffic, roadside actors, then scenery (in that order of random draws)."""
    road, lighting, cfg = _road(rng)
    t = (np.asarray(timestamps_us, np.int64) - timestamps_us[0]) / 1e6
    v_ego = rng.uniform(*cfg["v"])
    lane_e = int(rng.integers(road.lanes_per_dir))
    d_ego = road.lane_d(lane_e)
    s_ego = 30.0 + v_ego * t
    ex, ey, epsi = road.to_world(s_ego, np.full(len(t), d_ego))
    T_rig_world = _pose(ex, ey, np.zeros(len(t)), epsi)
    b = _Builder(rng, road, t, s_ego, d_ego, v_ego)
    s0, s1 = s_ego[0] - 40.0, s_ego[-1] + 160.0
    sp = _featured(b, lane_e)
    _traffic(b, lane_e)
    town = road.road_type in ("urban", "residential")
    if town:
        _town_roadside(b, s0, s1)
    else:
        _open_roadside(b)
    world = World(road, lighting, np.asarray(timestamps_us, np.int64), T_rig_world, b.actors,
                  s_range=(s0 - 20.0, s1 + 60.0))
    _scenery(world, rng, s0 - 20.0, s1 + 60.0)
    if town:
        world.crosswalks.append(sp)
    return world


def _scenery(world: World, rng, s0: float, s1: float) -> None:
    """Buildings, trees and lamps along both sides of the road (static, world frame)."""
    road = world.road
    kerb = road.half_width
    rt = road.road_type
    for side in (-1, 1):
        s = s0
        while s < s1:
            if rt == "urban":
                width, depth, height = rng.uniform(10, 25), rng.uniform(10, 16), rng.uniform(9, 30)
                setback, gap = 3.5, rng.uniform(0.0, 2.0)
            elif rt == "residential":
                width, depth, height = rng.uniform(8, 14), rng.uniform(8, 12), rng.uniform(5, 8)
                setback, gap = rng.uniform(7, 11), rng.uniform(6, 14)
            else:
                width = 0
            if width:
                sc = s + width / 2
                dc = side * (kerb + setback + depth / 2)
                x, y, psi = road.to_world(np.array([sc]), np.array([dc]))
                colour = tuple(int(c) for c in rng.integers(90, 220, 3))
                world.buildings.append(
                    {
                        "centre": np.array([x[0], y[0], height / 2]),
                        "dims": np.array([width, depth, height]),
                        "yaw": float(psi[0]),
                        "colour": colour,
                    }
                )
                s += width + gap
            else:
                s += 1e9
        # trees and lamps
        spacing = {"urban": 28.0, "residential": 12.0, "rural": 9.0, "highway": 14.0}[rt]
        s = s0 + rng.uniform(0, spacing)
        while s < s1:
            if rt in ("rural", "highway"):
                d = side * (kerb + rng.uniform(3.0, 25.0))
            elif rt == "residential":
                d = side * (kerb + rng.uniform(4.0, 6.0))
            else:
                d = side * (kerb + 2.6)
            x, y, _ = road.to_world(np.array([s]), np.array([d]))
            kind = "tree" if (rt != "urban" and rng.random() < 0.85) else "lamp"
            world.billboards.append(
                {
                    "base": np.array([x[0], y[0], 0.0]),
                    "kind": kind,
                    "height": float(rng.uniform(6.0, 11.0) if kind == "tree" else 7.5),
                }
            )
            s += spacing * rng.uniform(0.6, 1.4)
