"""What a bullet's pass through a sensor costs (``collision.sensor.SensorLog.passes``), in one process.

Box3D's large_pyramid (5050 cubes, 1/60 s x 4 substeps, semi-implicit Euler in flight, 1 thread)
with a sensor plate 1 cm thick beside it and a 1 cm ball at 100 m/s crossing the plate: 1.67 m a
step, 333 of its half-widths, so the step that carries it across samples it 256 times (the cap).
Prints each step's wall time (ms) and the sensor's events: the crossing step against the others.

Usage: ``python benchmarks/sensor_pass.py``.
"""

import time

import numba

import tumble as tb
from tumble.scenes import contact as C
from tumble.solver.contact import SoftStepSettings


def main():
    numba.set_num_threads(1)
    world, settings = C.build("large_pyramid")
    world.add_body(tb.Box((0.01, 4.0, 4.0)), fixed=True, sensor=True, position=(60.0, 0.0, 2.0), name="plate")
    bullet = world.add_body(tb.Sphere(0.005), mass=0.01, position=(55.3, 0.0, 2.0), velocity=(100.0, 0, 0),
                            name="bullet")
    sim = tb.Simulator(world, dt=settings["dt"], integrator="semi-implicit-euler",
                       contact_settings=SoftStepSettings(substeps=4))
    sim.step(1)  # compile
    for k in range(6):
        t0 = time.perf_counter()
        sim.step(1)
        print(f"step {k}: bullet at x = {world.x[bullet.index][0]:.3f} m, {(time.perf_counter() - t0) * 1e3:.1f} ms")
    print(sim.sensor_events())


if __name__ == "__main__":
    main()
