"""USD export of a trajectory (``.usd``, ``.usda``, ``.usdc``) through ``usd-core`` (pxr).

What the stage holds:

* metadata: ``upAxis = "Z"``, ``metersPerUnit = 1``, ``timeCodesPerSecond`` and
  ``framesPerSecond`` = the trajectory's frame rate, ``startTimeCode = 0``,
  ``endTimeCode = F - 1``; ``defaultPrim = /World``; the layer's customLayerData
  ``tumble`` has the time of frame 0 (time code k is ``time[0] + k / fps``).
* ``/World`` (Xform), and under it one Xform per body, in body order, named
  after the body made into a valid, unique USD identifier (the body's own name
  is its ``displayName`` and ``customData["tumble:name"]``). Its xformOpOrder is
  ``[xformOp:translate, xformOp:orient]`` (double3 and quatd, so samples are
  stored exactly): translate is the body's **centre of mass**, orient is its
  orientation (USD quaternions are (real, imaginary) like tumble's), time-sampled
  at time code = frame index. A fixed body has one default value, no samples.
* A body out of the simulation at some frames (``World.set_enabled``:
  ``Trajectory.enabled`` False there), fixed or not, has its Xform's
  ``visibility`` time-sampled: ``invisible`` from each frame it is disabled,
  ``inherited`` from each frame it is enabled (a sample at frame 0 and one
  per change; a token is held between samples, so it vanishes and appears at
  once). Bodies present throughout have no visibility opinion.
* Under each body Xform a ``Mesh`` named ``mesh``: points in the body frame
  (the shape shifted by ``-com_offset``, so it appears where the user put the
  shape), faceVertexCounts, faceVertexIndices, vertex normals, extent,
  ``subdivisionScheme = "none"`` (a box stays a box), and a constant
  displayColor (linear RGB of the body's colour, grey for fixed bodies).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .meshes import (SENSOR_OPACITY, absent_flags, body_color, body_meshes, enabled_flags, fixed_flags, frame_rate,
                     sensor_flags, srgb_to_linear)

SUFFIXES = (".usd", ".usda", ".usdc")
ROOT_PATH = "/World"


def prim_names(names) -> list[str]:
    """Valid, unique USD identifiers for ``names``: ``Tf.MakeValidIdentifier`` (a leading digit gets a ``_``
    before it), then ``_2``, ``_3``... on clashes."""
    from pxr import Tf

    used: set[str] = set()
    out = []
    for name in names:
        text = str(name)
        if text[:1].isdigit():  # keep the digit: "1st" -> "_1st", not "_st"
            text = "_" + text
        base = Tf.MakeValidIdentifier(text) or "body"
        candidate, k = base, 1
        while candidate in used:
            k += 1
            candidate = f"{base}_{k}"
        used.add(candidate)
        out.append(candidate)
    return out


def build_stage(traj, stage) -> None:
    """Fill ``stage`` (an empty ``Usd.Stage``) with ``traj``: see the module's docstring."""
    from pxr import Gf, Sdf, UsdGeom, Vt

    from ..trajectory import check_trajectory

    check_trajectory(traj)  # InputError naming the key of a value that cannot be written
    names = [str(n) for n in traj.names]
    fixed = fixed_flags(traj)
    sensor = sensor_flags(traj)
    position = np.asarray(traj.position, dtype=float)
    orientation = np.asarray(traj.orientation, dtype=float)
    time = np.asarray(traj.time, dtype=float)
    n_frames = len(time)
    if n_frames == 0 and names:
        raise ValueError("the trajectory has no frames")
    fps = frame_rate(traj)
    enabled = enabled_flags(traj)
    absent = absent_flags(enabled)  # bodies disabled at some frame: visibility samples hide them there

    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.LinearUnits.meters)
    stage.SetTimeCodesPerSecond(fps)
    stage.SetFramesPerSecond(fps)
    stage.SetStartTimeCode(0.0)
    stage.SetEndTimeCode(float(max(n_frames - 1, 0)))
    from .. import __version__

    layer = stage.GetRootLayer()
    layer.customLayerData = {"tumble": {"version": __version__, "time_of_frame_0": float(time[0]) if n_frames else 0.0,
                                        "frames": n_frames, "translate": "centre of mass"}}
    layer.documentation = "tumble trajectory: one Xform per body (translate = centre of mass, orient = orientation)"

    world = UsdGeom.Xform.Define(stage, ROOT_PATH)
    stage.SetDefaultPrim(world.GetPrim())
    meshes = body_meshes(traj)
    for i, prim_name in enumerate(prim_names(names)):
        xf = UsdGeom.Xform.Define(stage, f"{ROOT_PATH}/{prim_name}")
        prim = xf.GetPrim()
        if hasattr(prim, "SetDisplayName"):
            prim.SetDisplayName(names[i])
        prim.SetCustomDataByKey("tumble:name", names[i])
        prim.SetCustomDataByKey("tumble:body_index", i)
        prim.SetCustomDataByKey("tumble:com_offset", Gf.Vec3d(*map(float, traj.com_offset[i])))
        prim.SetCustomDataByKey("tumble:fixed", bool(fixed[i]))
        if sensor[i]:
            prim.SetCustomDataByKey("tumble:sensor", True)
        translate = xf.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
        orient = xf.AddOrientOp(UsdGeom.XformOp.PrecisionDouble)
        if fixed[i] or n_frames == 0:
            if n_frames:
                translate.Set(Gf.Vec3d(*position[0, i]))
                orient.Set(Gf.Quatd(*orientation[0, i]))
        else:  # time samples written on the layer directly, inside one change block: ~30x faster than Attribute.Set
            t_path, q_path = translate.GetAttr().GetPath(), orient.GetAttr().GetPath()
            xs, qs = position[:, i].tolist(), orientation[:, i].tolist()  # Python floats: faster into Gf
            with Sdf.ChangeBlock():
                for f in range(n_frames):
                    layer.SetTimeSample(t_path, float(f), Gf.Vec3d(*xs[f]))
                    layer.SetTimeSample(q_path, float(f), Gf.Quatd(*qs[f]))
        if absent[i]:
            visibility = xf.CreateVisibilityAttr()
            on = enabled[:, i]
            for f in np.flatnonzero(np.r_[True, on[1:] != on[:-1]]):  # frame 0 and each change
                visibility.Set(UsdGeom.Tokens.inherited if on[f] else UsdGeom.Tokens.invisible, float(f))

        vm, _ = meshes[i]
        mesh = UsdGeom.Mesh.Define(stage, f"{ROOT_PATH}/{prim_name}/mesh")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(vm.vertices, dtype=np.float32)))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(vm.faces), 3, dtype=np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(vm.faces.reshape(-1), dtype=np.int32)))
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(vm.normals, dtype=np.float32)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
        mesh.CreateDoubleSidedAttr(bool(vm.double_sided))
        lo = vm.vertices.min(axis=0) if len(vm.vertices) else np.zeros(3)
        hi = vm.vertices.max(axis=0) if len(vm.vertices) else np.zeros(3)
        mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]))
        color = srgb_to_linear(body_color(i, bool(fixed[i])))
        mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*color)]))
        mesh.GetDisplayColorPrimvar().SetInterpolation(UsdGeom.Tokens.constant)
        if sensor[i]:  # translucent, so what it holds shows
            mesh.CreateDisplayOpacityAttr(Vt.FloatArray([SENSOR_OPACITY]))
            mesh.GetDisplayOpacityPrimvar().SetInterpolation(UsdGeom.Tokens.constant)


def export_usd(traj, path) -> Path:
    """Write ``traj`` as a USD stage at ``path`` (.usd and .usdc: binary crate; .usda: text); returns the path.

    The file is written under a temporary name in the same folder and renamed
    into place, so no reader sees half a file. See the module's docstring for
    what the stage holds.
    """
    from pxr import Usd

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise ValueError(f"USD file name must end in {', '.join(SUFFIXES)}, got {path.name!r}")
    stage = Usd.Stage.CreateInMemory()
    build_stage(traj, stage)
    return write_stage(stage, path)


def write_stage(stage, path: Path) -> Path:
    """Export ``stage``'s root layer to ``path`` (its suffix says the format) under a temporary
    name in the same folder, renamed into place: no reader sees half a file."""
    from ..trajectory import atomic_path

    with atomic_path(path, suffix=path.suffix.lower()) as tmp:
        if not stage.GetRootLayer().Export(tmp):
            raise OSError(f"USD could not write {path}")
    return path
