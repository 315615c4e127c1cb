"""What an MJCF model observes with: its ``<site>`` frames and its fixed and tracking ``<camera>``s
(``Robot.sites``, ``Robot.cameras``), and its ``<sensor>`` elements, read from the world as MuJoCo computes them
(``Robot.sensor_data(sim)``: {name: values}, MuJoCo's ``data.sensor(name).data``).

Read (MuJoCo's definitions, XML reference "sensor"; frames in the world unless said):

- ``jointpos``, ``jointvel``: a hinge's or slide's position and rate (``Kinematics.qpos``, ``qvel``;
  a ball's quaternion and rates);
- ``framepos``, ``framequat``, ``framexaxis``, ``frameyaxis``, ``framezaxis``, ``framelinvel``,
  ``frameangvel`` of a ``site`` or an ``xbody`` (the body's frame), without ``reftype``;
- ``velocimeter``, ``gyro``: a site's linear and angular velocity in the site's frame;
- ``rangefinder``: the distance along the site's +z to the first shape not of the site's body (-1:
  none), a ``World.ray_cast``;
- ``touch``: the sum of the normal forces (N, the mean over the last step) of the contacts of the
  site's body whose points lie in the site's volume (sphere, capsule, cylinder, box, ellipsoid);
  a sleeping body (its contacts not solved) keeps the last reading taken while it was awake (it
  rests on the same forces; read it each step, or turn sleeping off, to have one);
- ``force``, ``torque``: what the joint into the site's body does on it over the last step (the
  joint's reaction, ``Robot.joint_reactions``: force, and torque about the site), in the site's
  frame (the parent's action on the child: MuJoCo's sign); a site on a welded body (merged into
  its parent: no joint to measure) or on a free one is left off;
- ``subtreecom``: the centre of mass of a body and the bodies below it;
- ``clock``: the simulated time.

- ``actuatorpos``, ``actuatorvel``, ``actuatorfrc``: an actuator's length gear q (or gear times its
  tendon's length), its rate, and its force gain ctrl + b0 + b1 l + b2 l' (clipped to its
  forcerange: MuJoCo's ``actuator_force`` at the present state; tumble applies a servo's spring
  and damper implicitly over the step); ``jointactuatorfrc``: the joint's generalized actuator
  force, the sum of each actuator's force times its moment arm on the joint (``qfrc_actuator``);
- ``tendonpos``, ``tendonvel``: a fixed tendon's length sum coef_i q_i and its rate.

Left off (``Robot.sensors_left_off``, names): the others (accelerometer, the limit and
friction-loss sensors...), frame sensors of geoms or of a body's inertial frame, and any with
``reftype``: tumble does not compute what they measure the way MuJoCo does, and a sensor reads,
never acts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .mjcf_control import floats as _floats
from .mjcf_xml import framed, place
from .math3d import matrix_to_quat

FRAME = ("framepos", "framequat", "framexaxis", "frameyaxis", "framezaxis", "framelinvel", "frameangvel")
SITE = ("velocimeter", "gyro", "rangefinder", "touch", "force", "torque")
ACTUATION = ("actuatorpos", "actuatorvel", "actuatorfrc", "jointactuatorfrc", "tendonpos", "tendonvel")
READ = ("jointpos", "jointvel", "subtreecom", "clock") + FRAME + SITE + ACTUATION


@dataclass
class MjcfSensor:
    """One sensor: ``name``, ``kind`` (its tag), ``objtype`` ("site", "xbody", "joint", "body" or
    ""), ``objname`` (the site, body or joint it reads)."""

    name: str
    kind: str
    objtype: str
    objname: str


def read_sensors(root, out):
    """``out.sensors`` (the ones read) and ``out.sensors_left_off`` (names) of the ``<sensor>``
    sections."""
    seen = set()
    for group in root.findall("sensor"):
        for e in (e for e in group if isinstance(e.tag, str)):
            name = e.get("name") or f"sensor{len(seen)}"
            key = f"sensor.{e.tag}[{name}]"
            if name in seen:
                raise InputError("duplicate sensor name", key)
            seen.add(name)
            a = e.attrib
            if e.tag not in READ or "reftype" in a or "refname" in a:
                out.sensors_left_off.append(name)
                continue
            if e.tag in ("jointpos", "jointvel", "jointactuatorfrc"):
                objtype, objname = "joint", a.get("joint")
            elif e.tag in ("actuatorpos", "actuatorvel", "actuatorfrc"):
                objtype, objname = "actuator", a.get("actuator")
            elif e.tag in ("tendonpos", "tendonvel"):
                objtype, objname = "tendon", a.get("tendon")
            elif e.tag == "subtreecom":
                objtype, objname = "body", a.get("body")
            elif e.tag in SITE:
                objtype, objname = "site", a.get("site")
            elif e.tag in FRAME:
                objtype, objname = a.get("objtype"), a.get("objname")
                if objtype not in ("site", "xbody"):
                    out.sensors_left_off.append(name)
                    continue
            else:  # clock
                objtype, objname = "", ""
            if objtype and not objname:
                raise InputError(f"missing the {objtype} it reads", key)
            if e.tag in ("force", "torque") and objname in out.sites:
                link = out.sites[objname][0]
                joint = next((j for j in out.model.joints if j.child == link), None)
                if joint is None or joint.kind in ("fixed", "floating"):
                    out.sensors_left_off.append(name)  # no joint into the site's body to measure
                    continue
            if objtype == "actuator" and objname is not None and objname not in out.actuators:
                out.sensors_left_off.append(name)  # an actuator tumble leaves off (on a site...): not read
                continue
            if objtype == "joint" and e.tag == "jointactuatorfrc" and objname in {
                    j.name for j in out.model.joints if j.kind not in ("revolute", "continuous", "prismatic")}:
                out.sensors_left_off.append(name)  # a ball's or free joint's: no actuator drives it here
                continue
            known = {"site": out.sites, "xbody": out.anchors, "body": out.anchors,
                     "joint": {j.name: j for j in out.model.joints}, "actuator": out.actuators,
                     "tendon": out.tendons}.get(objtype)
            if known is not None and objname not in known:
                raise InputError(f"unknown {objtype} {objname!r}", key)
            out.sensors.append(MjcfSensor(name, e.tag, objtype, objname))


def subtree_com(robot, link: str, o: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(3,) m, world: the centre of mass of ``link`` and the links below it (MuJoCo's
    ``subtree_com``) at the link frames o (L, 3), R (L, 3, 3) (``Kinematics._frames``), from the
    model's own link masses and centres: a welded body merged into its parent counts as itself,
    and the virtual links between the joints of one body (which MuJoCo does not have) not at all."""
    kin = robot.kinematics
    top = kin.index[link]
    virtual = set(robot.virtual_links)
    mass, moment = 0.0, np.zeros(3)
    for k, name in enumerate(kin.links):
        if not kin.ancestor[k, top] or name in virtual:
            continue
        part = robot.model.links[name]
        mass += part.mass
        moment += part.mass * (o[k] + R[k] @ part.center)
    return moment / mass if mass > 0.0 else o[top].copy()


def _in_site(kind: str, size: np.ndarray, p: np.ndarray) -> bool:
    """Whether the point p (3,) in the site's frame lies in its volume (MuJoCo's site shapes)."""
    if kind == "sphere":
        return float(p @ p) <= size[0] ** 2
    if kind == "capsule":
        z = min(max(p[2], -size[1]), size[1])
        return p[0] ** 2 + p[1] ** 2 + (p[2] - z) ** 2 <= size[0] ** 2
    if kind == "cylinder":
        return p[0] ** 2 + p[1] ** 2 <= size[0] ** 2 and abs(p[2]) <= size[1]
    if kind == "ellipsoid":
        return float(np.sum((p / size) ** 2)) <= 1.0
    return bool(np.all(np.abs(p) <= size))  # box


def sensor_values(robot, sim) -> dict:
    """{sensor name: (k,) values} of ``robot.sensors`` at the world's present state (``sim``: the
    Simulator stepping it, for the clock, the joint readings' whole turns and the contacts)."""
    world = robot.world
    kin = robot.kinematics
    qpos = qvel = None
    joint_q = joint_qd = None
    out = {}
    for s in robot.sensors.values():
        if s.kind in ACTUATION:
            if joint_q is None:  # {joint: q}, {joint: q'} of the hinges and slides
                qpos = kin.qpos(sim) if qpos is None else qpos
                qvel = kin.qvel() if qvel is None else qvel
                one = [c for c in kin.coordinates if c.qvel.stop - c.qvel.start == 1 and c.kind != "floating"]
                joint_q = {c.name: float(qpos[c.qpos][0]) for c in one}
                joint_qd = {c.name: float(qvel[c.qvel][0]) for c in one}
            if s.kind in ("tendonpos", "tendonvel"):
                values = joint_q if s.kind == "tendonpos" else joint_qd
                out[s.name] = np.array([sum(c * values[j] for j, c in robot.tendons[s.objname])])
            elif s.kind == "jointactuatorfrc":  # MuJoCo's qfrc_actuator of the joint
                out[s.name] = np.array([sum(arm * a.force(joint_q, joint_qd) for a in robot.actuators.values()
                                            for j, arm in a.moments() if j == s.objname)])
            else:
                a = robot.actuators[s.objname]
                if s.kind == "actuatorfrc":
                    out[s.name] = np.array([a.force(joint_q, joint_qd)])
                else:
                    length, rate = (a.given or a).length_and_rate(joint_q, joint_qd)
                    out[s.name] = np.array([length if s.kind == "actuatorpos" else rate])
            continue
        if s.kind in ("jointpos", "jointvel"):
            c = kin.by_name[s.objname]
            if s.kind == "jointpos":
                qpos = kin.qpos(sim) if qpos is None else qpos
                out[s.name] = qpos[c.qpos].copy()
            else:
                qvel = kin.qvel() if qvel is None else qvel
                out[s.name] = qvel[c.qvel].copy()
            continue
        if s.kind == "clock":
            out[s.name] = np.array([float(world.t)])
            continue
        if s.kind == "subtreecom":
            out[s.name] = subtree_com(robot, s.objname, *kin._frames(None))
            continue
        if s.objtype == "site":
            link = robot.sites[s.objname][0]
            o, R = robot.site_pose(s.objname)
        else:  # xbody: the body's frame, its link frame moved back by the joint's anchor
            link = s.objname
            lo, R = robot.link_pose(link)
            o = lo - R @ robot.anchors[link]
        body = robot.links[link]
        i = body.index
        v = body.point_velocity(o)
        w = np.array(body.omega, dtype=float)
        if s.kind == "framepos":
            out[s.name] = o
        elif s.kind == "framequat":
            out[s.name] = matrix_to_quat(np.ascontiguousarray(R))
        elif s.kind in ("framexaxis", "frameyaxis", "framezaxis"):
            out[s.name] = R[:, "xyz".index(s.kind[5])].copy()
        elif s.kind == "framelinvel":
            out[s.name] = v
        elif s.kind == "frameangvel":
            out[s.name] = w
        elif s.kind == "velocimeter":
            out[s.name] = R.T @ v
        elif s.kind == "gyro":
            out[s.name] = R.T @ w
        elif s.kind == "rangefinder":
            hit = world.ray_cast(o, R[:, 2], exclude=i)
            d = float(hit.distance[0])
            out[s.name] = np.array([d if np.isfinite(d) else -1.0])
        elif s.kind in ("force", "torque"):
            joint = kin.parent_joint[link]
            F, torque = robot.joint_reactions(sim)[joint.name] if sim is not None else (np.zeros(3), np.zeros(3))
            anchor = robot.link_pose(link)[0]  # a joint turns about its child link's origin
            # MuJoCo's sign: what the parent does on the child (checked against it)
            out[s.name] = R.T @ (F if s.kind == "force" else torque + np.cross(anchor - o, F))
        else:  # touch
            total = 0.0
            last = robot.__dict__.setdefault("_touch_last", {})
            sleep = None if sim is None else sim.sleep
            if sleep is not None and i < len(sleep.awake) and not sleep.awake[i]:
                # asleep: its contacts are not solved, and it rests as it did when it fell asleep,
                # on the forces it had then (a box on the floor read 0 once asleep: measured)
                out[s.name] = np.array([last.get(s.name, 0.0)])
                continue
            if sim is not None:
                contacts = sim.contacts()
                kind, size = robot.site_shapes[s.objname]
                for k in np.flatnonzero((contacts.body_a == i) | (contacts.body_b == i)):
                    if _in_site(kind, size, R.T @ (contacts.point[k] - o)):
                        total += max(float(contacts.normal_impulse[k]), 0.0)
                total /= sim.dt
            last[s.name] = total
            out[s.name] = np.array([total])
    return out


def _sites_and_cameras(reader, element, cls: str, key: str, link: str, anchor: np.ndarray, out):
    """The element's ``<site>``s and ``<camera>``s, in ``link``'s frame (the body frame less
    ``anchor``). A camera looks along its frame's -z with y up (MuJoCo's); ``fovy`` in degrees
    whatever the compiler's angle; ``resolution`` its image size (default 160 x 120). Cameras
    whose ``mode`` is not ``fixed`` (tracking ones) are not read (module docstring)."""
    for tag, table in (("site", out.sites), ("camera", out.cameras)):
        for k, (e, ecls, frame) in enumerate(framed(reader, element, (tag,), cls, key)):
            a = reader.attributes(e, ecls)
            name = a.get("name") or f"{link}_{tag}{k}"
            ekey = f"{key}.{tag}[{name}]"
            if name in table:
                raise InputError(f"duplicate {tag} name", ekey)
            position, R = place(frame, *reader.pose(a, ekey))
            if tag == "site":
                table[name] = (link, position - anchor, R)
                size = _floats(a.get("size", "0.005"), f"{ekey}.size", (1, 2, 3))
                out.site_shapes[name] = (a.get("type", "sphere"), np.resize(size, 3) if len(size) < 3 else size)
                continue
            mode = a.get("mode", "fixed")
            if mode not in ("fixed", "track", "trackcom"):
                continue  # targetbody, targetbodycom: not read
            fovy = float(_floats(a.get("fovy", "45"), f"{ekey}.fovy", (1,))[0])
            if not 0.0 < fovy < 180.0:
                raise InputError(f"must be between 0 and 180 degrees, got {fovy:g}", f"{ekey}.fovy")
            size = (160, 120)
            if "resolution" in a:
                w, h = _floats(a["resolution"], f"{ekey}.resolution", (2,))
                if not (w == int(w) and h == int(h) and 1 <= w <= 8192 and 1 <= h <= 8192):
                    raise InputError(f"expected two whole numbers of pixels, got {a['resolution']!r}",
                                     f"{ekey}.resolution")
                if (w, h) != (1, 1):  # MuJoCo's default, "the window's size": tumble's default instead
                    size = (int(w), int(h))
            table[name] = (link, position - anchor, R, fovy, size, mode)


class _SubtreeCom:
    """A ``trackcom`` camera's ``track``: the world centre of mass (3,) m of ``link``'s subtree of
    ``robot`` now (MuJoCo's ``subtree_com``). A class rather than a closure, so that the camera, the
    robot holding it and an environment made of them pickle with the standard pickler."""

    def __init__(self, robot, link: str):
        self.robot, self.link = robot, link

    def __call__(self, world) -> np.ndarray:
        return subtree_com(self.robot, self.link, *self.robot.kinematics._frames(None))


def _camera(robot, link, position, R, fovy, size, mode):
    """A ``tb.Camera`` on ``link``'s body from an MJCF camera (its frame in the link's): mounted
    (``fixed``), or following the body's frame origin (``track``) or its subtree's centre of mass
    (``trackcom``) at the offset and world orientation it has in the model's pose (MuJoCo's, at
    qpos0: ``robot.qpos0``)."""
    from .camera import Camera

    p, Rl = robot.link_frames[link]  # the link in its body's frame
    eye = p + Rl @ position
    body = robot.links[link]
    common = dict(body=body, fov_deg=fovy, width=size[0], height=size[1])
    if mode == "fixed":
        return Camera(position=eye, target=eye - Rl @ R[:, 2], up=Rl @ R[:, 1], **common)
    kin = robot.kinematics
    o, Rf = kin._frames(robot.qpos0)  # the model's pose
    k = kin.index[link]
    Rb = Rf[k] @ Rl.T
    shape_origin = o[k] - Rb @ p
    eye_w, R_w = shape_origin + Rb @ eye, Rb @ Rl @ R  # the camera in the world at the model's pose
    body_origin = p - Rl @ robot.anchors.get(link, np.zeros(3))  # MuJoCo's body frame origin, in the body's frame
    if mode == "track":
        followed, bodies, track = shape_origin + Rb @ body_origin, (), "point"
    else:
        bodies = ()
        followed = subtree_com(robot, link, o, Rf)
        track = _SubtreeCom(robot, link)
    offset = eye_w - followed
    return Camera(position=offset, target=offset - R_w[:, 2], up=R_w[:, 1], track=track, point=body_origin,
                  bodies=bodies, **common)
