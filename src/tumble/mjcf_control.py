"""MJCF models' actuation and constraints beside their tree (``tumble.mjcf``): the joint actuators
in MuJoCo's general form and their controls (``MjcfActuator``, ``apply_controls``: MuJoCo's
``data.ctrl``), ``<equality>`` connect and weld as joints, and the ``contype``/``conaffinity``
rule between the model's bodies. Read by ``mjcf._read``, applied by ``mjcf._build`` and
``Robot.set_controls``."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .errors import InputError
from .math3d import matrix_to_quat, quat_to_matrix
from .urdf import _finite

if TYPE_CHECKING:
    from .mjcf import MjcfModel

# the joint actuators read (MuJoCo's shortcuts of <general>, and <general> itself)
ACTUATORS = ("motor", "position", "velocity", "general")


def floats(text, key, counts) -> np.ndarray:
    """The numbers of an attribute; ``counts``: the allowed counts."""
    try:
        values = [float(t) for t in str(text).split()]
    except ValueError:
        raise InputError(f"expected numbers, got {text!r}", key) from None
    if len(values) not in counts:
        want = " or ".join(str(c) for c in counts)
        raise InputError(f"expected {want} number{'s' if max(counts) > 1 else ''}, got {text!r}", key)
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"expected finite numbers, got {text!r}", key)
    return np.array(values)


def whole_number(text, key, minimum: int, what: str = "a whole number") -> int:
    """An attribute's integer, at least ``minimum``: InputError naming ``key`` otherwise."""
    try:
        value = int(text)
    except (TypeError, ValueError):
        value = None
    if value is None or value < minimum:
        raise InputError(f"expected {what} >= {minimum}, got {text!r}", key)
    return value


@dataclass
class MjcfActuator:
    """An ``<actuator>`` on a joint in MuJoCo's general form: the actuator force f = gain ctrl + b0 +
    b1 l + b2 l' on the length l = gear q (ctrl clipped to ``ctrlrange``, f to ``forcerange``, when
    given), the joint's generalized force gear f. ``motor``: gain 1, no bias; ``position``: gain
    kp, bias (0, -kp, -kv); ``velocity``: gain kv, bias (0, 0, -kv); ``general``: gainprm[0],
    biasprm[:3] (affine) or none. On the joint: a stiffness k = -gear^2 b1 and damping c = -gear^2
    b2 (a PD drive, implicit), the rest gear (gain ctrl + b0) as the drive's target times k when
    k > 0, else as an applied torque or force. The joint's own spring (stiffness to springref) and
    damper act beside that drive as the joint's passive spring-damper, which the drive's cap (the
    forcerange) does not hold (MuJoCo's passive forces act beside the actuators': ``mjcf.load_mjcf``
    writes them; ``Robot.joint_passive``: {joint: (stiffness, springref, damping)} of the joints so
    driven). ``ctrl``: the control now (MuJoCo's ``data.ctrl``,
    0 at the start; ``Robot.set_controls``). On a fixed tendon (length sum coef_i q_i) the force
    acts on each of its joints with the moment arm coef_i gear (MuJoCo's transmission): an applied
    torque or force on each (motors and bias-free general actuators only)."""

    name: str
    kind: str
    joint: str
    gear: float = 1.0
    ctrlrange: tuple | None = None
    forcerange: tuple | None = None
    gain: float = 1.0
    bias: tuple = (0.0, 0.0, 0.0)
    ctrl: float = 0.0
    tendon: tuple = ()  # on a fixed tendon (``joint`` None): ((joint, coef), ...), each joint's moment arm coef gear
    # a servo on a tendon made this joint's actuator (``_tendon_servos``): the actuator as the file gives it
    # (its tendon, gear and bias), for MuJoCo's actuator force and moment arms (``mjcf_sensors``)
    given: "MjcfActuator | None" = None
    # a position actuator's ``dampratio``: its kv is set from the model's inertia at qpos0 once the robot
    # is built (``resolve_dampratios``)
    dampratio: float = 0.0

    def length_and_rate(self, qpos: dict, qvel: dict) -> tuple:
        """(l, l') of MuJoCo's actuator length, gear q or gear sum coef_i q_i, from {joint: q}, {joint: q'}."""
        if self.tendon:
            return (self.gear * sum(c * qpos[j] for j, c in self.tendon),
                    self.gear * sum(c * qvel[j] for j, c in self.tendon))
        return self.gear * qpos[self.joint], self.gear * qvel[self.joint]

    def force(self, qpos: dict, qvel: dict) -> float:
        """MuJoCo's ``actuator_force``: gain ctrl + b0 + b1 l + b2 l' (ctrl already clipped to its
        range), clipped to ``forcerange``; the file's actuator for a tendon servo."""
        a = self.given or self
        length, rate = a.length_and_rate(qpos, qvel)
        f = a.gain * a.ctrl + a.bias[0] + a.bias[1] * length + a.bias[2] * rate
        if a.forcerange is not None:
            f = min(max(f, a.forcerange[0]), a.forcerange[1])
        return f

    def moments(self) -> tuple:
        """((joint, moment arm), ...): where MuJoCo applies the force (gear on its joint; gear coef_i
        on each joint of its tendon)."""
        a = self.given or self
        return tuple((j, a.gear * c) for j, c in a.tendon) if a.tendon else ((a.joint, a.gear),)

    @property
    def rate_servo(self) -> bool:
        """A damper without a spring whose force is clipped whole (a velocity actuator with a
        forcerange): on its joint a drive of damping gear^2 kv pulling to the target velocity
        ctrl / gear, capped at the forcerange (``P_TARGET_RATE``), not an effort beside a damper."""
        return self.forcerange is not None and self.stiffness == 0.0 and self.damping > 0.0

    @property
    def stiffness(self) -> float:
        return -self.gear * self.gear * self.bias[1]

    @property
    def damping(self) -> float:
        return -self.gear * self.gear * self.bias[2]

    def drive(self) -> float:
        """gear (gain ctrl + b0): N m or N, the part of the force that is not spring or damper."""
        force = self.gain * self.ctrl + self.bias[0]
        if self.forcerange is not None and self.stiffness == 0.0:  # a motor's force, clipped whole
            force = min(max(force, self.forcerange[0]), self.forcerange[1])
        return self.gear * force


def apply_controls(robot, sim, controls: dict):
    """``Robot.set_controls``: set the actuators' ``ctrl`` and write each joint they drive (its
    drive target, its applied effort) from all its actuators."""
    from .joints import P_EFFORT, P_TARGET, P_TARGET_RATE, SliderJoint

    given = []
    for name, value in controls.items():
        actuator = robot.actuators.get(name)
        if actuator is None:
            raise InputError(f"unknown actuator {name!r} of robot {robot.name!r}", "controls")
        u = _finite(value, f"controls.{name}")
        if actuator.ctrlrange is not None:
            u = min(max(u, actuator.ctrlrange[0]), actuator.ctrlrange[1])
        given.append((actuator, u))
    for actuator, u in given:
        actuator.ctrl = u
        if actuator.given is not None:
            actuator.given.ctrl = u
    touched = []
    for actuator, _ in given:
        touched += [j for j, _c in actuator.tendon] if actuator.tendon else [actuator.joint]
    for joint in dict.fromkeys(touched):
        on = [a for a in robot.actuators.values() if a.joint == joint]
        stiffness = sum(a.stiffness for a in on)
        servo = sum(a.drive() for a in on if a.stiffness > 0.0)
        effort = sum(a.drive() for a in on if a.stiffness == 0.0 and not a.rate_servo)
        effort += sum(c * a.drive() for a in robot.actuators.values() for j, c in a.tendon if j == joint)
        values = {P_EFFORT: effort}
        # the record's fields too (``Robot._write``: the record says what acts; an edit of one of its
        # fields rewrites the whole row from them)
        fields = {"force" if isinstance(robot.joints.get(joint), SliderJoint) else "torque": effort}
        if joint in getattr(robot, "servo_drives", {}):  # the file's drive back (after a set_motor...)
            columns, drive_fields = robot.servo_drives[joint]
            values.update(columns)
            fields.update(drive_fields)
        if stiffness > 0.0:
            # the servos' springs, one spring: -K (q - target) with K their sum and the target their
            # weighted mean, sum gear (gain ctrl + b0) / K (the joint's own spring to springref is its
            # passive spring, beside the drive: ``mjcf.load_mjcf``)
            values[P_TARGET] = fields["target"] = servo / stiffness
        rate = [a for a in on if a.rate_servo]
        if rate:
            # the velocity servos' pull, sum gear (gain ctrl + b0) = sum d_i w_i (d_i = gear^2 kv, w_i =
            # ctrl / gear + ...), as the drive's damping (every actuator's on the joint) times its
            # target velocity: clipped whole by the drive's cap, as MuJoCo clips the force
            damping = sum(a.damping for a in on)
            pull = sum(a.gear * (a.gain * a.ctrl + a.bias[0]) for a in rate)
            values[P_TARGET_RATE] = fields["target_velocity"] = pull / damping
        robot._write(sim, joint, values, fields)


def _tendon_servos(out: MjcfModel):
    """The position, velocity and biased actuators on fixed tendons (``out.tendon_servos``), each made an
    actuator on one joint. Such an actuator's bias couples the tendon's joints (its spring acts on
    the length sum c_i q_i); tumble takes it where joint equalities tie every joint of the tendon to
    one of them, q_i = a_i + r_i q (MuJoCo Menagerie's grippers: Franka's "split" tendon over its two
    fingers, whose equality mirrors them): then the tendon's length is L = L0 + C q (L0 = sum c_i a_i,
    C = sum c_i r_i), and the actuator is one on that joint with gear gear C and bias b0 + b1 gear L0
    (the same generalized force on the one coordinate left, so the same motion; its force reaches
    the other joints through their equalities). Else one line."""
    follows = {}  # joint1: (joint2, a0, a1) of the linear joint equalities
    for kind, _eq, joint1, joint2, coef in out.equalities:
        if kind == "joint" and joint2 is not None and not np.any(np.asarray(coef)[2:]):
            follows[joint1] = (joint2, float(coef[0]), float(coef[1]))
    for name, key in out.tendon_servos:
        actuator = out.actuators[name]
        joints = [j for j, _c in actuator.tendon]
        leader = None
        for candidate in joints:
            if all(j == candidate or (j in follows and follows[j][0] == candidate) for j in joints):
                leader = candidate
                break
        if leader is None:
            raise InputError("a position, velocity or biased actuator on a tendon is supported when joint "
                             "equalities tie the tendon's joints to one of them (else it would couple them)", key)
        L0 = C = 0.0
        for j, c in actuator.tendon:
            a0, a1 = (0.0, 1.0) if j == leader else follows[j][1:]
            L0 += c * a0
            C += c * a1
        gear = actuator.gear * C
        b0, b1, b2 = actuator.bias
        joint_actuator = MjcfActuator(name, actuator.kind, leader, gear, actuator.ctrlrange, actuator.forcerange,
                                      actuator.gain, (b0 + b1 * actuator.gear * L0, b1, b2), given=actuator,
                                      dampratio=actuator.dampratio)
        k, c, limit = out.drives.get(leader, (0.0, 0.0, 0.0))
        if joint_actuator.stiffness > 0.0 or joint_actuator.rate_servo:
            fr = actuator.forcerange
            limit += math.inf if fr is None else abs(gear) * max(abs(fr[0]), abs(fr[1]))
        out.drives[leader] = (k + joint_actuator.stiffness, c + joint_actuator.damping, limit)
        out.actuators[name] = joint_actuator  # in its place: MuJoCo's actuator order (ctrl) kept


def resolve_dampratios(robot):
    """Each position actuator's ``dampratio`` made its kv as MuJoCo makes it (mj_setConst): kv = 2
    dampratio sqrt(kp m), m = 1 / (r^T M^-1 r) the inertia the actuator sees through its moment arms
    r (gear on its joint, gear coef_i on a tendon's joints) at qpos0, M the joint-space mass matrix
    with armature; then the damping of the joints it drives (gear^2 kv, summed with the other
    actuators') is written. Without it a dampratio was read as no damping at all: the servo rang."""
    todo = [a for a in robot.actuators.values() if a.dampratio > 0.0]
    if not todo:
        return
    from .joints import P_DAMPING

    kin = robot.kinematics
    Minv = np.linalg.inv(kin.mass_matrix(robot.qpos0))
    for a in todo:
        r = np.zeros(kin.nv)
        for joint, arm in a.moments():
            r[kin.by_name[joint].qvel.start] += arm
        kv = 2.0 * a.dampratio * math.sqrt(a.gain * (1.0 / float(r @ Minv @ r)))
        if not math.isfinite(kv) or not math.isfinite(a.gear * a.gear * kv):
            raise InputError(f"the damping it makes (kv = {kv:g}) is past the float range",
                             f"actuator.{a.kind}[{a.name}].dampratio")
        for record in (a, a.given):
            if record is not None:
                record.bias = (record.bias[0], record.bias[1], -kv)
    passive = getattr(robot, "joint_passive", {})
    for joint in dict.fromkeys(a.joint for a in todo):
        if joint not in passive:
            continue  # given ``joint_targets``: the caller's drive (it took the actuators' damping before)
        # the actuators' dampings (the joint's own damper is its passive one, beside them)
        damping = sum(b.damping for b in robot.actuators.values() if b.joint == joint)
        robot._write(None, joint, {P_DAMPING: damping}, {"damping": damping})


def _limited(a: dict, flag: str, attr: str, key: str, reader):
    """An actuator's (lo, hi) range ``attr`` when ``flag`` ("ctrllimited", "forcelimited": true,
    false, or auto: limited when the range is given, under ``<compiler autolimits>``), else None."""
    value = a.get(flag, "auto")
    if value not in ("true", "false", "auto"):
        raise InputError(f"expected true, false or auto, got {value!r}", f"{key}.{flag}")
    if value == "false" or (value == "auto" and not (reader.autolimits and attr in a)):
        return None
    if attr not in a:
        raise InputError(f"{flag} without a {attr}", f"{key}.{attr}")
    lo, hi = floats(a[attr], f"{key}.{attr}", (2,))
    if lo > hi:
        raise InputError(f"the range is the wrong way round: {lo:g} > {hi:g}", f"{key}.{attr}")
    return float(lo), float(hi)


def _inherited_range(out: MjcfModel, joint, factor: float, ctrlrange, key: str) -> tuple:
    """A position actuator's ``inheritrange``: its ctrlrange the range of its joint scaled by ``factor``
    about the range's middle (MuJoCo's compiler; the joint's range in radians or metres)."""
    if ctrlrange is not None:
        raise InputError("give ctrlrange or inheritrange, not both", key)
    if not factor > 0.0:
        raise InputError(f"must be >= 0, got {factor:g}", key)
    j = next((j for j in out.model.joints if j.name == joint), None)
    if j is None or j.kind not in ("revolute", "prismatic") or j.lower is None or j.upper is None \
            or not (math.isfinite(j.lower) and math.isfinite(j.upper)):
        raise InputError("inheritrange needs a joint with a range (a tendon's range is not read)", key)
    middle, half = 0.5 * (j.lower + j.upper), 0.5 * (j.upper - j.lower)
    return middle - factor * half, middle + factor * half


def _actuators(reader, root, out: MjcfModel, joint_names):
    """The joint actuators (``MjcfActuator``) and, per joint, their drive (stiffness, damping, force
    limit) into ``out.drives``."""
    for act in root.findall("actuator"):
        for e in act:
            if not isinstance(e.tag, str):
                continue  # an XML comment
            out.ctrl_names.append(None)  # MuJoCo's ctrl order counts every actuator (keyframes' ctrl)
            if e.tag not in ACTUATORS:
                continue  # read and left off (module docstring)
            a = reader.attributes(e, "main")
            if "joint" not in a and "tendon" not in a:
                continue  # on a site: left off
            name = a.get("name") or f"actuator{len(out.actuators)}"
            out.ctrl_names[-1] = name
            key = f"actuator.{e.tag}[{a.get('name', a.get('joint', a.get('tendon')))}]"
            if name in out.actuators:
                raise InputError("duplicate actuator name", key)
            joint, tendon = a.get("joint"), ()
            if joint is None:
                if a["tendon"] not in out.tendons:
                    raise InputError(f"unknown tendon {a['tendon']!r}", f"{key}.tendon")
                tendon = out.tendons[a["tendon"]]
            elif joint not in joint_names:
                raise InputError(f"unknown joint {joint!r} ({e.tag} actuators drive joints)", f"{key}.joint")
            else:
                kind = next((j.kind for j in out.model.joints if j.name == joint), "free")
                if kind not in ("revolute", "continuous", "prismatic"):
                    raise InputError(f"an actuator on a {kind} joint is not supported (only hinge and slide)",
                                     f"{key}.joint")
            gear = float(floats(a["gear"], f"{key}.gear", (1, 6))[0]) if "gear" in a else 1.0
            ctrlrange = _limited(a, "ctrllimited", "ctrlrange", key, reader)
            forcerange = _limited(a, "forcelimited", "forcerange", key, reader)

            def number(attr, default):
                return float(floats(a.get(attr, default), f"{key}.{attr}", (1,))[0])

            dampratio = 0.0
            if e.tag == "motor":
                gain, bias = 1.0, (0.0, 0.0, 0.0)
            elif e.tag == "position":
                kp, kv = number("kp", "1"), number("kv", "0")
                if "timeconst" in a and number("timeconst", "0") != 0.0:
                    raise InputError("a timeconst (activation dynamics) is not supported", f"{key}.timeconst")
                if "inheritrange" in a and number("inheritrange", "0") != 0.0:
                    ctrlrange = _inherited_range(out, joint, number("inheritrange", "0"), ctrlrange, f"{key}.inheritrange")
                if "dampratio" in a:
                    if "kv" in a:
                        raise InputError("give kv or dampratio, not both", f"{key}.dampratio")
                    dampratio = number("dampratio", "0")
                    if not dampratio >= 0.0:
                        raise InputError(f"must be >= 0, got {dampratio:g}", f"{key}.dampratio")
                gain, bias = kp, (0.0, -kp, -kv)
            elif e.tag == "velocity":
                kv = number("kv", "1")
                gain, bias = kv, (0.0, 0.0, -kv)
            else:  # general
                for attr, allowed in (("dyntype", ("none",)), ("gaintype", ("fixed",)),
                                      ("biastype", ("none", "affine"))):
                    if a.get(attr, allowed[0]) not in allowed:
                        raise InputError(f"{attr} {a[attr]!r} is not supported (only {' or '.join(allowed)})",
                                         f"{key}.{attr}")
                gain = float(floats(a.get("gainprm", "1"), f"{key}.gainprm", range(1, 11))[0])
                bias = (0.0, 0.0, 0.0)
                if a.get("biastype", "none") == "affine":
                    b = floats(a.get("biasprm", "0 0 0"), f"{key}.biasprm", range(1, 11))
                    bias = tuple(float(v) for v in (list(b) + [0.0, 0.0])[:3])
            actuator = MjcfActuator(name, e.tag, joint, gear, ctrlrange, forcerange, gain, bias, tendon=tendon,
                                    dampratio=dampratio)
            if actuator.stiffness < 0.0 or actuator.damping < 0.0:
                raise InputError("a negative stiffness or damping (bias) is not supported", key)
            if tendon:
                out.actuators[name] = actuator
                if actuator.stiffness or actuator.damping:
                    out.tendon_servos.append((name, key))  # after the equalities: ``_tendon_servos``
                continue
            k, c, limit = out.drives.get(joint, (0.0, 0.0, 0.0))
            # a servo's cap: its forcerange (a velocity actuator's too: f = kv (ctrl - l') clipped
            # whole, the drive's target velocity; refused before the drive had one)
            if actuator.stiffness > 0.0 or actuator.rate_servo:
                limit += math.inf if forcerange is None else abs(gear) * max(abs(forcerange[0]), abs(forcerange[1]))
            out.drives[joint] = (k + actuator.stiffness, c + actuator.damping, limit)
            out.actuators[name] = actuator


def _equalities(reader, root, out: MjcfModel, names):
    """``<equality>``: ``connect`` (body1, body2 or the world, ``anchor`` in body1's frame: a ball
    joint there, closing a loop), ``weld`` (the two bodies' relative pose at the model's pose: a
    fixed joint) and ``joint`` (``_joint_equality``); ``active="false"`` ones are left off. Into
    ``out.equalities``."""
    for group in root.findall("equality"):
        for k, e in enumerate(group):
            a = reader.attributes(e, "main")
            name = a.get("name") or f"equality{len(out.equalities)}"
            key = f"equality.{e.tag}[{a.get('name', k)}]"
            if e.tag not in ("connect", "weld", "joint"):
                raise InputError(f"<equality><{e.tag}> is not supported (only connect, weld and joint)", key)
            if a.get("active", "true") not in ("true", "false"):
                raise InputError(f"expected true or false, got {a['active']!r}", f"{key}.active")
            if e.tag == "joint":
                coupling = _joint_equality(a, key, out)
                if a.get("active", "true") == "true":
                    out.equalities.append(("joint", name, *coupling))
                continue
            if "site1" in a or "site2" in a:
                raise InputError("an equality between sites is not supported (give body1, body2)", key)
            bodies = (a.get("body1"), a.get("body2", "world"))
            for role, body in zip(("body1", "body2"), bodies):
                if body not in names:
                    raise InputError(f"unknown body {body!r}", f"{key}.{role}")
            if bodies[0] == bodies[1]:
                raise InputError("body1 and body2 are the same body", key)
            if e.tag == "weld" and "relpose" in a and list(floats(a["relpose"], f"{key}.relpose", (7,))) != \
                    [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]:
                raise InputError("a weld's relpose is not supported (its pose at the model's pose is kept)",
                                 f"{key}.relpose")
            anchor = floats(a.get("anchor", "0 0 0"), f"{key}.anchor", (3,))
            if a.get("active", "true") == "true":
                out.equalities.append((e.tag, name, bodies[0], bodies[1], anchor))


def _joint_equality(a, key: str, out: MjcfModel):
    """``<equality><joint joint1 joint2 polycoef>``: (joint1, joint2, coefficients (5,)), joint1 following
    joint2 as q1 - q1_0 = a0 + a1 (q2 - q2_0) + ... + a4 (q2 - q2_0)^4 (MuJoCo's; a ``GearJoint``); without
    joint2 (None), joint1 locked at q1 - q1_0 = a0."""
    kinds = {j.name: j.kind for j in out.model.joints}
    ends = []
    for role in ("joint1", "joint2"):
        joint = a.get(role)
        if joint is None and role == "joint2":  # joint1 locked at polycoef[0] from its reference
            ends.append(None)
            continue
        if joint not in kinds:
            raise InputError(f"unknown joint {joint!r}", f"{key}.{role}")
        if kinds[joint] not in ("revolute", "continuous", "prismatic"):
            raise InputError("a joint equality couples hinge and slide joints", f"{key}.{role}")
        ends.append(joint)
    if ends[0] == ends[1]:
        raise InputError("joint1 and joint2 are the same joint", key)
    given = floats(a.get("polycoef", "0 1 0 0 0"), f"{key}.polycoef", range(1, 6))
    coef = np.array([0.0, 1.0, 0.0, 0.0, 0.0])  # MuJoCo's default, for the numbers left out
    coef[:len(given)] = given
    return ends[0], ends[1], coef


def ref_polynomial(coef, ref1: float, ref2: float) -> tuple:
    """MuJoCo's joint equality q1 - ref1 = sum a_j (q2 - ref2)^j (its polycoef ``coef`` (5,), about
    the joints' qpos0) as a polynomial in q2 itself, q1 = sum c_k q2^k (``GearJoint``'s, whose
    coordinates are MuJoCo's qpos): c_k = sum_{j >= k} a_j C(j, k) (-ref2)^(j - k), plus ref1 in c_0.
    The coefficients as given when both refs are 0."""
    a = [float(v) for v in coef]
    if ref1 == 0.0 and ref2 == 0.0:
        return tuple(a)
    c = [sum(a[j] * math.comb(j, k) * (-ref2) ** (j - k) for j in range(k, len(a))) for k in range(len(a))]
    c[0] += ref1
    return tuple(c)


def _add_equalities(world, robot, equalities, refs=None):
    """The equality constraints as joints at the model's pose: ``connect`` a ``BallJoint`` at its anchor
    (body1's frame), ``weld`` a ``FixedJoint``, ``joint`` a ``GearJoint`` (joint1 following joint2 by
    polycoef, about their ``refs``: ``ref_polynomial``); named "MODEL/NAME", in ``robot.equalities``.
    The two bodies of a connect or weld do not touch (``collide_connected`` False: a loop's links
    overlap where they meet)."""
    refs = refs or {}
    from .joints import BallJoint, FixedJoint, GearJoint

    def body(link):
        return "world" if link == "world" else robot.links[link]

    for kind, name, body1, body2, anchor in equalities:
        key = f"equality.{kind}[{name}]"
        if kind == "joint":  # body1, body2, anchor: joint1, joint2, polycoef
            record = GearJoint(joint=robot.joints[body1], follows=None if body2 is None else robot.joints[body2],
                               polynomial=ref_polynomial(anchor, refs.get(body1, 0.0),
                                                         0.0 if body2 is None else refs.get(body2, 0.0)),
                               name=f"{robot.name}/{name}")
        elif body1 != "world" and body2 != "world" and robot.links[body1] is robot.links[body2]:
            continue  # both welded into one body: nothing left to hold
        elif kind == "connect":
            origin, R = robot.link_pose(body1)  # the worldbody's frame too: where the model was put
            record = BallJoint(body(body1), body(body2), anchor=origin + R @ anchor, name=f"{robot.name}/{name}")
        else:
            at = robot.link_pose(body2 if body2 != "world" else body1)[0]
            record = FixedJoint(body(body1), body(body2), anchor=at, name=f"{robot.name}/{name}")
        try:
            world.add_joint(record)
        except InputError as err:
            raise InputError(err.problem, f"{key}.{err.key}" if err.key else key) from None
        robot.equalities[name] = record


def _exclude_by_masks(world, robot, masks: dict, keep=frozenset()):
    """MuJoCo's contype/conaffinity rule between the model's own bodies: two geoms may touch when
    (contype1 & conaffinity2) or (contype2 & conaffinity1); a pair of bodies none of whose geoms
    may touch is excluded (``world.exclude_collision``). Per body pair, not per geom: two bodies
    of which some geoms may touch collide with all their geoms (a compound collides whole). The
    model's bodies against the scene's: left to the bodies' filters (MuJoCo's default masks 1
    and 1 meet any nonzero mask). ``keep``: (lo, hi) body pairs never excluded (explicit pairs)."""
    per_body: dict = {}
    for link, pairs in masks.items():
        per_body.setdefault(robot.links[link].index, []).extend(pairs)
    bodies = sorted(per_body)
    for i, a in enumerate(bodies):
        for b in bodies[i + 1:]:
            if (a, b) in keep:
                continue
            if not any((ta & cb) or (tb & ca) for ta, ca in per_body[a] for tb, cb in per_body[b]):
                world.exclude_collision(a, b)


def _keyframes(root, out: MjcfModel):
    """``<keyframe><key name qpos qvel ctrl/>``: raw numbers, checked against the model's sizes once
    the robot is built (``check_keyframes``)."""
    for group in root.findall("keyframe"):
        for k, e in enumerate(group.findall("key")):
            name = e.get("name") or f"key{len(out.keyframes)}"
            key = f"keyframe.key[{name}]"
            if name in out.keyframes:
                raise InputError("duplicate keyframe name", key)
            out.keyframes[name] = tuple(
                None if e.get(attr) is None else np.asarray(floats(e.get(attr), f"{key}.{attr}", range(1, 100000)), dtype=float)
                for attr in ("qpos", "qvel", "ctrl"))


def check_keyframes(robot, keyframes: dict, ctrl_names: list):
    """Each key's qpos, qvel and ctrl the model's sizes (MuJoCo's nq, nv, nu), or an InputError."""
    kin = robot.kinematics
    for name, values in keyframes.items():
        for attr, v, size in zip(("qpos", "qvel", "ctrl"), values, (kin.nq, kin.nv, len(ctrl_names))):
            if v is not None and v.shape != (size,):
                raise InputError(f"expected {size} numbers, got {v.size}", f"keyframe.key[{name}].{attr}")


def apply_keyframe(robot, name, sim):
    """``Robot.reset_to_keyframe``: the key's qpos (default the model's pose), qvel (default rest) and
    ctrl (default: the controls are left as they are), its free joints taken from the model's frame
    into the world's (where ``load_mjcf`` put the model)."""
    if name not in robot.keyframes:
        raise InputError(f"unknown keyframe {name!r} of robot {robot.name!r}", "keyframe")
    qpos, qvel, ctrl = robot.keyframes[name]
    kin = robot.kinematics
    base_p, base_R = robot.link_pose("world")
    q = robot.qpos0.copy() if qpos is None else qpos.copy()
    qd = np.zeros(kin.nv) if qvel is None else qvel.copy()
    for c in kin.coordinates:
        if c.kind != "floating":
            continue
        a, v = c.qpos.start, c.qvel.start
        if qpos is not None:
            q[a:a + 3] = base_p + base_R @ q[a:a + 3]
            q[a + 3:a + 7] = matrix_to_quat(np.ascontiguousarray(base_R @ quat_to_matrix(q[a + 3:a + 7] / np.linalg.norm(q[a + 3:a + 7]))))
        qd[v:v + 3] = base_R @ qd[v:v + 3]
    kin.set_state(q, qd, sim)
    if ctrl is not None:
        apply_controls(robot, sim, {n: float(u) for n, u in zip(robot.ctrl_names, ctrl) if n is not None})


def _tendons(reader, root, out: MjcfModel, joint_names):
    """``<tendon><fixed>``: the joints and coefficients of each fixed tendon (``out.tendons``), for
    the actuators on them. A fixed tendon with no range, stiffness, damping or friction loss does
    nothing by itself (MuJoCo's default): read. One that would couple its joints (a limited
    range, stiffness, damping, frictionloss) and a spatial tendon are refused with one line."""
    for group in root.findall("tendon"):
        for e in (e for e in group if isinstance(e.tag, str)):
            name = e.get("name") or f"tendon{len(out.tendons)}"
            key = f"tendon.{e.tag}[{name}]"
            if e.tag != "fixed":
                raise InputError(f"a <{e.tag}> tendon is not supported (fixed tendons driven by motors are)", key)
            if name in out.tendons:
                raise InputError("duplicate tendon name", key)
            a = reader.attributes(e, "main", tag="tendon")
            for attr in ("stiffness", "damping", "frictionloss"):
                if attr in a and float(floats(a[attr], f"{key}.{attr}", (1,))[0]) != 0.0:
                    raise InputError(f"a tendon's {attr} is not supported (it would couple its joints)",
                                     f"{key}.{attr}")
            limited = a.get("limited", "auto")
            if limited == "true" or (limited == "auto" and reader.autolimits and "range" in a):
                raise InputError("a tendon's range is not supported (it would couple its joints)", f"{key}.range")
            parts = []
            for j in e.findall("joint"):
                joint = j.get("joint")
                if joint not in joint_names:
                    raise InputError(f"unknown joint {joint!r}", f"{key}.joint")
                parts.append((joint, float(floats(j.get("coef", "1"), f"{key}.joint[{joint}].coef", (1,))[0])))
            out.tendons[name] = tuple(parts)
