"""MIT-format push recordings made by a simulator bridge does not use: MuJoCo (issue 11, "a mismatched-world proof").

bridge's own proofs (`bridge prove`) build their worlds from bridge's scene builder in Drake, so whatever they
vary, the contact model, the rod and the way a push is driven are bridge's. This generator shares nothing with
bridge but the dataset's file format and the shapes' outlines: MuJoCo's soft contacts, the object resting on a
grid of small spheres (uniform pressure by construction, not a tetrahedral fan), a rod on a stiff position servo
of its own gains recorded where its encoders put it, friction of each pair given directly
(MuJoCo takes the larger of two geoms' coefficients: every object geom has 0), a 1 ms step. Each case conceals
at most one effect by a physical mechanism:

| effect | mechanism |
| --- | --- |
| none | nothing (the pairs' coefficients are drawn away from the object database's 0.25 in every case) |
| friction | the surface's coefficient x 2.2 or / 2.2 |
| mass | a dense slug at the centre: +100 % mass |
| com_offset | a dense slug off the centre (+80 % mass) putting the centre of mass 10 mm off |
| surface_tilt | gravity turned by 1 deg about a random horizontal axis (the sheet tilted) |
| friction_patch | the sheet built of tiles: a half-plane or a strip across the pushes' way of another coefficient (x or / 1.8) |
| latency | the rod's timestamps 60 ms early or late |
| pusher_offset | the recorded rod 4 mm off the real one (a calibration error) |
| hidden_obstacle | a welded box (25-35 mm, turned) or round post (radius 10-16 mm) beside the pushes' way |

The world's other differences from the database: contact stiffness (MuJoCo's solref 3-6 ms), the rod's and the
sheet's coefficients drawn (x or / 1.3-1.8), the density of the steel (x 0.95-1.05), motion-capture noise 0.05-0.3
mm and 0.5-2 mrad with a few timestamps stepping back, force noise 0.05 N and gain x 0.95-1.05.

    python benchmarks/independent_pushes.py OUT --shape ellip1 --effect latency --seed 3 [--pushes 8]

writes OUT/<case>/*.h5 (the dataset's names, so the shape is known) and OUT/<case>/truth.json.
"""
from __future__ import annotations

import argparse
import json
import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

EFFECTS = ("none", "friction", "mass", "com_offset", "surface_tilt", "friction_patch", "latency", "pusher_offset",
           "hidden_obstacle")
LOCAL = ("friction_patch", "hidden_obstacle")  # effects with a place: pushes go its way
ROD_RADIUS = 0.00476  # m (the dataset's README)
THICKNESS = 0.0128  # m
DENSITY = 7950.0  # kg/m^3, stainless steel 304
DB_FRICTION = 0.25  # the object database's coefficient of the block, the sheet and the rod
RATE = 250.0  # Hz of the dataset's streams
STEP = 0.001  # s, MuJoCo's time step
SPHERE = 0.001  # m, radius of the support spheres
SUPPORTS = 20  # support spheres: MuJoCo twists an object on many soft contacts harder than Coulomb friction does
#               (measured: 175 spheres 1.3-1.7 x the torque of uniform pressure, about 20 spheres 1.16-1.22 x; its
#               pyramidal cones twist right but slide up to 40 % further at 45 deg)
TWIST = 0.84  # the support points drawn this much towards the centroid (a start; `calibrated_twist` sets it per
#               shape so that the world's spin-down matches uniform pressure's mu m g <r> within 2 %)
FORCE_WINDOW = 20  # steps (20 ms) the force sensor averages over: MuJoCo's rod contact chatters step to step
ROD_MASS = 0.3  # kg moved by each axis of the servo
SERVO_KP, SERVO_KV = 30000.0, 350.0  # N/m, N s/m: a stiff position servo (a kinematic rod kicks the object ahead
#                                      of it at every contact in MuJoCo: 16-87 % of the pushing time in contact,
#                                      where the real MIT pushes stay in contact 93-100 %; the servo: 56-97 %)
GENERATOR = 4  # bumped whenever the worlds it makes change: cached cases of another version are made again
MAX_OBJECT_SPEED = 1.0  # m/s: a pushed object faster than this blew up (the rod moves at most 0.15 m/s); such a
#                         push is drawn again (v3 kept one: an ellipse squeezed past a post at 477 N flew 0.5 m)


@dataclass
class World:
    """Everything that differs from the database in one case; written to truth.json."""

    shape: str
    effect: str
    mu_surface: float
    mu_rod: float
    density: float
    solref: float  # s, MuJoCo's contact time constant
    tilt: tuple[float, float] = (0.0, 0.0)  # rad, downhill components (x, y) of the sheet's slope
    slug: tuple[float, float, float] = (0.0, 0.0, 0.0)  # kg, x m, y m (object frame): an added dense mass
    patch: dict = field(default_factory=dict)  # kind "half" | "strip", point, normal, width, mu
    obstacle: dict = field(default_factory=dict)  # kind "box" | "post", xy, size, yaw
    latency: float = 0.0  # s: the rod moved this much later than its stamps say (bridge's `latency` kind)
    rod_offset: tuple[float, float] = (0.0, 0.0)  # m: real rod = recorded + offset
    pose_noise: tuple[float, float] = (1e-4, 1e-3)  # m, rad
    force_noise: float = 0.05  # N
    force_gain: float = 1.0
    way: float = 0.0  # rad: the pushes' common direction (local effects)
    centre: tuple[float, float] = (0.4, -0.1)  # m: where the object starts (the dataset's sheet region)


def outline(root: Path, shape: str) -> np.ndarray:
    return np.asarray(np.load(root / "obj" / f"{shape}_ext.npy"), dtype=float)


def inside(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule, vectorised over points."""
    x, y = points[:, 0:1], points[:, 1:2]
    a, b = poly, np.roll(poly, -1, axis=0)
    crosses = ((a[:, 1] > y) != (b[:, 1] > y)) & (
        x < (b[:, 0] - a[:, 0]) * (y - a[:, 1]) / np.where(b[:, 1] == a[:, 1], 1e-12, b[:, 1] - a[:, 1]) + a[:, 0])
    return np.count_nonzero(crosses, axis=1) % 2 == 1


def support_points(poly: np.ndarray, twist: float = TWIST) -> np.ndarray:
    """SUPPORTS points spread evenly over the outline (a centroidal Voronoi tessellation: k-means of a fine grid
    inside it, each point carrying an equal share of the weight), drawn `twist` towards the centroid."""
    from scipy.cluster.vq import kmeans2

    lo, hi = poly.min(axis=0), poly.max(axis=0)
    step = math.sqrt(float(np.prod(hi - lo)) / 20000)
    xs, ys = np.meshgrid(np.arange(lo[0] + step / 2, hi[0], step), np.arange(lo[1] + step / 2, hi[1], step))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    grid = grid[inside(grid, poly)]
    points, _ = kmeans2(grid, SUPPORTS, seed=1, minit="++", iter=100)
    _, c = area_centroid(poly)
    return c + twist * (points - c)


_TWISTS: dict[bytes, float] = {}


def calibrated_twist(poly: np.ndarray) -> float:
    """The `twist` at which a spin-down of the object (1 rad/s, mu 0.2) on its support spheres turns it as far as
    Coulomb friction under uniform pressure does: w0^2 I / (2 mu m g <r>), <r> the outline's mean distance from
    its centroid. A few secant steps on MuJoCo spin-downs; the turn goes as 1 / twist."""
    import mujoco

    key = np.asarray(poly, dtype=float).tobytes()
    if key in _TWISTS:
        return _TWISTS[key]
    _, c = area_centroid(poly)
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    g = np.random.default_rng(0).uniform(lo, hi, (200000, 2))
    mean_r = float(np.mean(np.linalg.norm(g[inside(g, poly)] - c, axis=1)))
    world = World("calibration", "none", 0.2, 0.2, DENSITY, 0.005)
    spin, twist = 1.0, TWIST
    for _ in range(4):
        model = mujoco.MjModel.from_xml_string(model_xml(world, poly, (0.3, 0.0, 0.0), twist))
        data = mujoco.MjData(model)
        body = model.body("object").id
        free = model.jnt_dofadr[[j for j in range(model.njnt) if model.jnt_type[j] == 0][0]]
        for _ in range(200):
            mujoco.mj_step(model, data)
        w0, q0 = data.body("object").xquat.copy(), None
        data.qvel[free + 5] = spin
        for _ in range(1500):
            mujoco.mj_step(model, data)
        w1 = data.body("object").xquat
        turned = 2 * math.atan2(w0[0] * w1[3] - w0[3] * w1[0] + w0[1] * w1[2] - w0[2] * w1[1], float(w0 @ w1))
        want = spin ** 2 * model.body_inertia[body].max() / (2 * 0.2 * model.body_mass[body] * 9.81 * mean_r)
        if abs(turned / want - 1) < 0.02:
            break
        twist *= turned / want  # torque ~ twist: turn ~ 1 / twist
    _TWISTS[key] = twist
    return twist


def _edge_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    a, b = poly, np.roll(poly, -1, axis=0)
    e = b - a
    t = np.clip(np.einsum("pkd,kd->pk", points[:, None, :] - a[None], e) / np.einsum("kd,kd->k", e, e), 0, 1)
    closest = a[None] + t[..., None] * e[None]
    return np.min(np.linalg.norm(points[:, None, :] - closest, axis=2), axis=1)


def area_centroid(poly: np.ndarray) -> tuple[float, np.ndarray]:
    a, b = poly, np.roll(poly, -1, axis=0)
    cross = a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]
    area = cross.sum() / 2
    c = ((a + b) * cross[:, None]).sum(axis=0) / (6 * area)
    return abs(area), c


# --- the MuJoCo model ---------------------------------------------------------------------------------------
def model_xml(world: World, poly: np.ndarray, start: tuple[float, float, float], twist: float | None = None) -> str:
    h = THICKNESS / 2
    verts = " ".join(f"{x:.6f} {y:.6f} {z:.6f}" for z in (-h, h) for x, y in poly)
    area, c = area_centroid(poly)
    spheres = "\n".join(
        f'<geom type="sphere" size="{SPHERE}" pos="{x:.5f} {y:.5f} {-h + SPHERE:.5f}" contype="1" conaffinity="1" '
        f'condim="3" friction="0 0 0" density="0" solref="{world.solref} 1"/>'
        for x, y in support_points(poly, calibrated_twist(poly) if twist is None else twist))
    slug = ""
    if world.slug[0] > 0:
        m, sx, sy = world.slug
        slug = (f'<geom type="cylinder" size="0.006 0.004" pos="{sx:.5f} {sy:.5f} 0" mass="{m:.5f}" contype="0" '
                f'conaffinity="0" rgba="0.2 0.2 0.2 1"/>')
    g = 9.81
    gx, gy = world.tilt  # a sheet sloping down along (gx, gy): gravity has that component in the sheet's frame
    gravity = f"{g * math.sin(gx):.6f} {g * math.sin(gy):.6f} {-g * math.cos(math.hypot(gx, gy)):.6f}"
    x0, y0, yaw = start
    tiles = _sheet(world)
    obstacle = ""
    if world.obstacle:
        o = world.obstacle
        if o["kind"] == "box":
            obstacle = (f'<geom type="box" size="{o["size"] / 2:.4f} {o["size"] / 2:.4f} 0.02" '
                        f'pos="{o["xy"][0]:.5f} {o["xy"][1]:.5f} 0.02" euler="0 0 {o["yaw"]:.4f}" contype="2" '
                        f'conaffinity="2" friction="{world.mu_rod} 0 0"/>')
        else:
            obstacle = (f'<geom type="cylinder" size="{o["size"]:.4f} 0.02" pos="{o["xy"][0]:.5f} {o["xy"][1]:.5f} '
                        f'0.02" contype="2" conaffinity="2" friction="{world.mu_rod} 0 0"/>')
    return f"""
<mujoco model="independent_push">
  <compiler angle="radian"/>
  <option timestep="{STEP}" gravity="{gravity}" cone="elliptic" integrator="implicitfast"/>
  <asset><mesh name="prism" vertex="{verts}"/></asset>
  <worldbody>
    {tiles}
    {obstacle}
    <body name="object" pos="{x0:.6f} {y0:.6f} {h:.6f}" euler="0 0 {yaw:.6f}">
      <freejoint/>
      <geom name="hull" type="mesh" mesh="prism" density="{world.density:.1f}" contype="2" conaffinity="2"
            friction="0 0 0" solref="{world.solref} 1"/>
      {spheres}
      {slug}
    </body>
    <body name="rod" pos="0 0 {h:.6f}">
      <joint name="rx" type="slide" axis="1 0 0" damping="0"/>
      <joint name="ry" type="slide" axis="0 1 0" damping="0"/>
      <geom name="rod" type="cylinder" size="{ROD_RADIUS} 0.004" mass="{ROD_MASS}" contype="2" conaffinity="2"
            friction="{world.mu_rod} 0 0" solref="{world.solref} 1"/>
    </body>
  </worldbody>
  <actuator>
    <position joint="rx" kp="{SERVO_KP}" kv="{SERVO_KV}"/>
    <position joint="ry" kp="{SERVO_KP}" kv="{SERVO_KV}"/>
  </actuator>
</mujoco>"""


def _sheet(world: World) -> str:
    """The sheet: a plane, or tiles (boxes flush at z = 0) when a patch of another coefficient is concealed."""
    if not world.patch:
        return f'<geom name="sheet" type="plane" size="2 2 0.01" contype="1" conaffinity="1" friction="{world.mu_surface} 0 0"/>'
    p = world.patch
    n = np.asarray(p["normal"], dtype=float)
    along = math.atan2(n[1], n[0])
    point = np.asarray(p["point"], dtype=float)
    big = 1.5
    # tiles along the normal: [-inf, 0) outside, [0, width) the patch (strip) or [0, inf) (half-plane), rest outside
    spans = [(-big, 0.0, world.mu_surface)]
    if p["kind"] == "half":
        spans.append((0.0, big, p["mu"]))
    else:
        spans += [(0.0, p["width"], p["mu"]), (p["width"], big, world.mu_surface)]
    out = []
    for k, (a, b, mu) in enumerate(spans):
        mid = point + n * (a + b) / 2
        out.append(f'<geom name="tile{k}" type="box" size="{(b - a) / 2:.5f} {big:.3f} 0.005" '
                   f'pos="{mid[0]:.5f} {mid[1]:.5f} -0.005" euler="0 0 {along:.5f}" contype="1" conaffinity="1" '
                   f'friction="{mu:.4f} 0 0"/>')
    return "\n    ".join(out)


@dataclass
class Push:
    start: tuple[float, float, float]  # object x, y, yaw
    rod0: np.ndarray  # rod centre at t = 0
    direction: np.ndarray
    speed: float  # m/s
    travel: float  # m
    hold: float = 0.15  # s before the rod moves
    after: float = 0.5  # s recorded after it stops

    ramp: float = 0.15  # s to reach the speed and to stop again (an arm's trajectory is smooth, not a step)

    @property
    def moving(self) -> float:
        return self.travel / self.speed + self.ramp  # s: a trapezoidal speed profile covering `travel`

    @property
    def duration(self) -> float:
        return self.hold + self.moving + self.after

    def rod(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rod centre and velocity at times t: a smooth (cosine) ramp up, the speed, a smooth ramp down."""
        tau = np.clip(t - self.hold, 0.0, self.moving)
        r, T, v = self.ramp, self.moving, self.speed
        up = np.minimum(tau, r)
        down = np.clip(tau - (T - r), 0.0, r)
        # integral of v (1 - cos(pi u / r)) / 2 over [0, u]
        ramp_int = lambda u: v * (u - r / math.pi * np.sin(math.pi * u / r)) / 2  # noqa: E731
        s = ramp_int(up) + v * np.clip(tau - r, 0.0, T - 2 * r) + (v * down - ramp_int(down))
        speed = np.where(tau < r, v * (1 - np.cos(math.pi * up / r)) / 2,
                         np.where(tau > T - r, v * (1 + np.cos(math.pi * down / r)) / 2, v))
        speed = np.where((t <= self.hold) | (t >= self.hold + T), 0.0, speed)
        return self.rod0 + s[:, None] * self.direction, speed[:, None] * self.direction


def simulate(world: World, poly: np.ndarray, push: Push) -> dict[str, np.ndarray]:
    """One push: the object's pose, the real rod's centre and the force on the rod at RATE."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(model_xml(world, poly, push.start))
    data = mujoco.MjData(model)
    rod_geom = model.geom("rod").id
    steps = int(round(push.duration / STEP))
    every = int(round(1.0 / (RATE * STEP)))
    times = np.arange(steps + 1) * STEP
    command, _ = push.rod(times)
    qx, qy = model.joint("rx").qposadr[0], model.joint("ry").qposadr[0]
    data.qpos[qx], data.qpos[qy] = command[0]
    out_t, pose, tip, force = [], [], [], []
    f6 = np.zeros(6)
    window = np.zeros((FORCE_WINDOW, 2))  # the sensor's filter: the mean force over its window
    for k in range(steps + 1):
        data.ctrl[:] = command[k]
        mujoco.mj_forward(model, data)
        f = np.zeros(3)
        for i in range(data.ncon):
            con = data.contact[i]
            if rod_geom not in (con.geom1, con.geom2):
                continue
            mujoco.mj_contactForce(model, data, i, f6)
            world_f = con.frame.reshape(3, 3).T @ f6[:3]  # force of geom1 on geom2, world frame
            f += world_f if con.geom2 == rod_geom else -world_f
        window[k % FORCE_WINDOW] = f[:2]
        if k % every == 0:
            x, y = data.body("object").xpos[:2]
            w, qx_, qy_, qz_ = data.body("object").xquat
            yaw = math.atan2(2 * (w * qz_ + qx_ * qy_), 1 - 2 * (qy_ ** 2 + qz_ ** 2))
            out_t.append(times[k])
            pose.append((x, y, yaw))
            tip.append((data.qpos[qx], data.qpos[qy]))  # where the encoders say the rod is
            force.append(window[:min(k + 1, FORCE_WINDOW)].mean(axis=0))
            if not np.all(np.isfinite(data.qpos)) or abs(data.body("object").xpos[2]) > 0.05:
                raise RuntimeError(f"MuJoCo replay of {world.shape} left the sheet at t = {times[k]:.2f} s")
            if len(pose) > 1 and math.dist(pose[-1][:2], pose[-2][:2]) * RATE > MAX_OBJECT_SPEED:
                raise RuntimeError(f"MuJoCo replay of {world.shape} blew up at t = {times[k]:.2f} s")
        if k < steps:
            mujoco.mj_step(model, data)
    return {"t": np.array(out_t), "pose": np.unwrap(np.array(pose), axis=0), "tip": np.array(tip),
            "force": np.array(force)}


# --- the case: effect, world, pushes --------------------------------------------------------------------------
def draw_world(shape: str, effect: str, rng: np.random.Generator, poly: np.ndarray) -> World:
    def away() -> float:  # a factor drawn away from 1
        f = rng.uniform(1.3, 1.8)
        return f if rng.random() < 0.5 else 1.0 / f

    world = World(shape, effect, DB_FRICTION * away(), DB_FRICTION * away(), DENSITY * rng.uniform(0.95, 1.05),
                  float(rng.uniform(0.003, 0.006)), pose_noise=(float(rng.uniform(5e-5, 3e-4)),
                                                                float(rng.uniform(5e-4, 2e-3))),
                  force_gain=float(rng.uniform(0.95, 1.05)), way=float(rng.uniform(-math.pi, math.pi)),
                  centre=(float(rng.uniform(0.3, 0.5)), float(rng.uniform(-0.2, 0.0))))
    area, _ = area_centroid(poly)
    mass = world.density * area * THICKNESS
    radius = math.sqrt(area / math.pi)
    d = np.array([math.cos(world.way), math.sin(world.way)])
    n_perp = np.array([-d[1], d[0]])
    cx, cy = world.centre
    if effect == "friction":
        world.mu_surface = DB_FRICTION * (2.2 if rng.random() < 0.5 else 1 / 2.2)
    elif effect == "mass":
        world.slug = (mass, 0.0, 0.0)
    elif effect == "com_offset":
        m = 0.8 * mass
        r = 0.010 * (mass + m) / m
        a = rng.uniform(-math.pi, math.pi)
        world.slug = (m, r * math.cos(a), r * math.sin(a))
    elif effect == "surface_tilt":
        a = rng.uniform(-math.pi, math.pi)
        world.tilt = (math.radians(1.0) * math.cos(a), math.radians(1.0) * math.sin(a))
    elif effect == "friction_patch":
        f = 1.8 if rng.random() < 0.5 else 1 / 1.8
        turn = rng.uniform(-0.5, 0.5)
        normal = np.array([math.cos(world.way + turn), math.sin(world.way + turn)])
        point = np.array([cx, cy]) + d * (radius + rng.uniform(0.005, 0.02))
        kind = "half" if rng.random() < 0.5 else "strip"
        world.patch = {"kind": kind, "point": point.tolist(), "normal": normal.tolist(),
                       "width": float(rng.uniform(0.03, 0.05)), "mu": world.mu_surface * f}
    elif effect == "latency":
        world.latency = 0.06 * (1 if rng.random() < 0.5 else -1)
    elif effect == "pusher_offset":
        a = rng.uniform(-math.pi, math.pi)
        world.rod_offset = (0.004 * math.cos(a), 0.004 * math.sin(a))
    elif effect == "hidden_obstacle":
        kind = "box" if rng.random() < 0.5 else "post"
        size = float(rng.uniform(0.025, 0.035)) if kind == "box" else float(rng.uniform(0.010, 0.016))
        half = size / 2 if kind == "box" else size
        side = 1 if rng.random() < 0.5 else -1
        xy = (np.array([cx, cy]) + d * (radius + half + rng.uniform(0.005, 0.015))
              + side * n_perp * (radius * rng.uniform(0.4, 0.8)))
        world.obstacle = {"kind": kind, "xy": xy.tolist(), "size": size, "yaw": float(rng.uniform(0, math.pi))}
    elif effect != "none":
        raise ValueError(f"unknown effect {effect!r}; effects: {', '.join(EFFECTS)}")
    return world


def design_pushes(world: World, poly: np.ndarray, rng: np.random.Generator, n: int) -> list[Push]:
    """Pushes like the dataset's: the rod 1-5 mm clear of the outline, straight at 20-150 mm/s for 30-60 mm, then
    still while the recording goes on. Any direction and yaw, or within 40 deg of the local effect's way."""
    local = world.effect in LOCAL
    pushes = []
    half = np.max(np.abs(poly), axis=0)
    for _ in range(n):
        x0 = world.centre[0] + rng.uniform(-0.01, 0.01)
        y0 = world.centre[1] + rng.uniform(-0.01, 0.01)
        yaw = rng.uniform(-math.pi, math.pi)
        phi = world.way + (rng.uniform(-0.7, 0.7) if local else rng.uniform(-math.pi, math.pi))
        d = np.array([math.cos(phi), math.sin(phi)])
        perp = np.array([-d[1], d[0]])
        aim = np.array([x0, y0]) + rng.uniform(-0.5, 0.5) * float(np.min(half)) * perp
        c, s = math.cos(yaw), math.sin(yaw)
        world_poly = poly @ np.array([[c, s], [-s, c]]) + np.array([x0, y0])
        clearance = rng.uniform(0.001, 0.005)
        # back along -d from the aim point until the rod is clear of the outline by the clearance
        p = aim - d * (float(np.max(half)) * 2)
        for t in np.linspace(0.0, float(np.max(half)) * 2, 2000):
            q = aim - d * (float(np.max(half)) * 2 - t)
            if inside(q[None], world_poly)[0] or _edge_distance(q[None], world_poly)[0] < ROD_RADIUS + clearance:
                break
            p = q
        travel = rng.uniform(0.03, 0.06) + clearance
        speed = float(rng.choice([0.01, 0.02, 0.05, 0.075, 0.1]))  # the dataset's speeds (mm/s: 10-100)
        pushes.append(Push((x0, y0, yaw), p, d, speed, travel))
    return pushes


def record(path: Path, world: World, push: Push, sim: dict, rng: np.random.Generator) -> None:
    """The streams as the dataset has them: unix clock, 250 Hz, a few object timestamps stepping back, the rod
    where the robot says it is (offset and clock as concealed), the force on the rod with noise and gain."""
    import h5py

    t = sim["t"]
    clock = 1.46e9 + rng.uniform(0, 3e7) + t
    sxy, syaw = world.pose_noise
    pose = sim["pose"] + np.column_stack([rng.normal(0, sxy, (len(t), 2)), rng.normal(0, syaw, len(t))])
    stamps = clock.copy()
    late = np.nonzero(rng.random(len(t)) < 0.01)[0]
    late = late[(late > 0) & (late < len(t) - 1)]
    stamps[late] = stamps[late - 1] - rng.uniform(2e-4, 1.5e-3, len(late))
    tip = sim["tip"] - np.asarray(world.rod_offset)
    force = world.force_gain * sim["force"] + rng.normal(0, world.force_noise, (len(t), 2))
    zeros = np.zeros(len(t))
    streams = {"object_pose": np.column_stack([stamps, pose]),
               "tip_pose": np.column_stack([clock - world.latency, tip, zeros]),
               "ft_wrench": np.column_stack([clock, force, zeros])}
    tmp = path.with_name(f".{path.name}.tmp")
    with h5py.File(tmp, "w") as handle:
        for name, array in streams.items():
            handle.create_dataset(name, data=array)
    os.replace(tmp, path)


def make_case(root: Path, out: Path, shape: str, effect: str, seed: int, n: int = 8) -> Path:
    rng = np.random.default_rng([seed, EFFECTS.index(effect), sum(map(ord, shape))])
    poly = outline(root, shape)
    world = draw_world(shape, effect, rng, poly)
    folder = out / f"{shape}_{effect}_s{seed}"
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for k, push in enumerate(design_pushes(world, poly, rng, n)):
        for _ in range(5):  # a push whose simulation blew up is drawn again
            try:
                sim = simulate(world, poly, push)
                break
            except RuntimeError:
                push = design_pushes(world, poly, rng, 1)[0]
        else:
            raise RuntimeError(f"{shape} {effect}: five pushes in a row blew up in MuJoCo")
        angle = math.atan2(push.direction[1], push.direction[0])
        name = (f"motion_surface=abs_shape={shape}_a=0_v={int(round(push.speed * 1000))}_i={k}.000_s=0.500_"
                f"t={angle:.3f}.h5")
        record(folder / name, world, push, sim, rng)
        moved = float(np.linalg.norm(sim["pose"][-1, :2] - sim["pose"][0, :2]))
        turned = math.degrees(float(sim["pose"][-1, 2] - sim["pose"][0, 2]))
        files.append({"file": name, "moved_mm": round(1e3 * moved, 1), "turned_deg": round(turned, 1),
                      "speed": push.speed, "peak_force_N": round(float(np.max(np.linalg.norm(sim["force"], axis=1))), 2)})
    (folder / "truth.json").write_text(json.dumps({"generator": GENERATOR, "world": asdict(world), "pushes": files},
                                                  indent=1) + "\n")
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--shape", default="ellip1")
    parser.add_argument("--effect", default="none", choices=EFFECTS)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--pushes", type=int, default=8)
    parser.add_argument("--dataset", default=os.environ.get("BRIDGE_MIT_PUSH",
                                                            str(Path(__file__).resolve().parents[2] / "shared"
                                                                / "datasets" / "mit-push")))
    args = parser.parse_args()
    folder = make_case(Path(args.dataset), Path(args.out), args.shape, args.effect, args.seed, args.pushes)
    print(json.dumps(json.loads((folder / "truth.json").read_text())["pushes"], indent=1))
    print(f"wrote {folder}")


if __name__ == "__main__":
    main()
