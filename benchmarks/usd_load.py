"""Loading USD stages with physics (``tb.load_usd``): how long a stage of N boxes takes to become a
World, split into OpenUSD's own parse (``UsdPhysics.LoadUsdPhysicsFromRange``) and tumble's mapping,
beside building the same World through the Python API (``World.add_body`` in a loop).

    PYTHONPATH=src python benchmarks/usd_load.py --n 100 1000 5000

Each stage: a static ground plane, N boxes of 20 cm with a physics material, on a grid 0.3 m
apart, and a chain of N / 10 revolute joints between consecutive boxes (a stage of bodies and
joints, as an Isaac Sim scene has). Medians of --repeats, each into a new World. No peer engine
on PyPI reads UsdPhysics (MuJoCo and PyBullet do not), so the API build is the reference. Writes
benchmarks/results/usd_load.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from contact import machine, md_table, write_results  # noqa: E402
from peers.common import median_time  # noqa: E402

import tumble as tb  # noqa: E402


def write_stage(path: Path, n: int):
    from pxr import Gf, Usd, UsdGeom, UsdPhysics, UsdShade

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdGeom.Xform.Define(stage, "/World")
    UsdPhysics.Scene.Define(stage, "/World/physicsScene")
    mat = UsdShade.Material.Define(stage, "/World/wood")
    api = UsdPhysics.MaterialAPI.Apply(mat.GetPrim())
    api.CreateDynamicFrictionAttr(0.6)
    api.CreateRestitutionAttr(0.1)
    plane = UsdGeom.Plane.Define(stage, "/World/ground")
    plane.GetAxisAttr().Set("Z")
    UsdPhysics.CollisionAPI.Apply(plane.GetPrim())
    side = int(n ** 0.5 + 0.999)
    for k in range(n):
        c = UsdGeom.Cube.Define(stage, f"/World/boxes/box{k}")
        c.GetSizeAttr().Set(0.2)
        c.AddTranslateOp().Set(Gf.Vec3d(0.3 * (k % side), 0.3 * (k // side), 0.1))
        prim = c.GetPrim()
        UsdPhysics.CollisionAPI.Apply(prim)
        UsdPhysics.RigidBodyAPI.Apply(prim)
        UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat, UsdShade.Tokens.weakerThanDescendants, "physics")
    for k in range(n // 10):
        j = UsdPhysics.RevoluteJoint.Define(stage, f"/World/joints/j{k}")
        j.CreateBody0Rel().SetTargets([f"/World/boxes/box{k}"])
        j.CreateBody1Rel().SetTargets([f"/World/boxes/box{k + 1}"])
        j.CreateAxisAttr("Y")
        j.CreateLocalPos0Attr(Gf.Vec3f(0.15, 0, 0))
        j.CreateLocalPos1Attr(Gf.Vec3f(-0.15, 0, 0))
    stage.GetRootLayer().Save()


def api_build(n: int):
    side = int(n ** 0.5 + 0.999)
    w = tb.World()
    wood = tb.Material(friction=0.6, restitution=0.1)
    w.add_body(tb.Plane(normal=(0, 0, 1)), fixed=True)
    for k in range(n):
        w.add_body(tb.Box(size=(0.2, 0.2, 0.2)), density=1000.0, position=(0.3 * (k % side), 0.3 * (k // side), 0.1),
                   material=wood)
    for k in range(n // 10):
        a = 1 + k
        w.add_joint(tb.HingeJoint(a, a + 1, anchor=w.x[a] + (0.15, 0, 0), axis=(0, 1, 0)))
    return w


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[100, 1000, 5000])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    from pxr import Usd, UsdPhysics

    parse = getattr(UsdPhysics, "UsdPhysicsLoadStageFromPrimRange", None) or UsdPhysics.LoadUsdPhysicsFromRange
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.n:
            path = Path(tmp) / f"boxes{n}.usda"
            write_stage(path, n)
            tb.load_usd(tb.World(), path)  # warm: imports, first trimesh and numba uses
            open_s = median_time(lambda: Usd.Stage.Open(str(path)), args.repeats)
            stage = Usd.Stage.Open(str(path))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                parse_s = median_time(lambda: parse(stage, ["/"]), args.repeats)
            load_s = median_time(lambda: tb.load_usd(tb.World(), path), args.repeats)
            api_s = median_time(lambda: api_build(n), args.repeats)
            world = tb.World()
            scene = tb.load_usd(world, path)
            assert world.body_count == n + 1 and len(scene.joints) == n // 10
            rows.append([n, n // 10, f"{open_s * 1e3:.1f}", f"{parse_s * 1e3:.1f}", f"{load_s * 1e3:.1f}",
                         f"{(load_s - open_s - parse_s) / (n + 1) * 1e6:.0f}", f"{api_s * 1e3:.1f}",
                         f"{load_s / api_s:.2f}"])
            print(rows[-1], flush=True)
    header = ["boxes", "joints", "open stage ms", "UsdPhysics parse ms", "tb.load_usd ms (all)",
              "tumble's mapping us/body", "API build ms", "load / API"]
    info = machine()
    text = (f"machine: {info}; median of {args.repeats}\n\n" + md_table(header, rows) + "\n")
    out = HERE / "results"
    out.mkdir(exist_ok=True)
    write_results(out, "usd_load", text, [dict(zip(header, r)) for r in rows], info)
    print(text)


if __name__ == "__main__":
    main()
