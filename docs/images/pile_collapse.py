"""Side views of BENCHMARKS.md's 1000-box pile at the default step (docs/contact.md, Known limits).

Run from the repository root: python docs/images/pile_collapse.py docs/images/pile_collapse.png
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

sys.path.insert(0, "src")
import tumble as tb
from tumble.scenes.contact import pile

REGION_EDGE = 3.8  # m: the grid's half-width 1.8 m + the region's 2 m margin
TIMES = [0.45, 0.8, 1.2, 1.6, 2.2, 4.0]  # s


def main(path: str) -> None:
    world, _ = pile(1000)
    sim = tb.Simulator(world)  # the default step, as the acceptance test
    fig, axes = plt.subplots(len(TIMES), 1, figsize=(7, 1.55 * len(TIMES)), sharex=True)
    t = 0.0
    moving = world.moving
    for ax, time in zip(axes, TIMES):
        sim.step(round((time - t) / sim.dt))
        t = time
        x = world.x[moving]
        ax.scatter(x[:, 0], x[:, 2], s=3, c="0.35", linewidths=0)
        for edge in (-REGION_EDGE, REGION_EDGE):
            ax.axvline(edge, color="tab:red", lw=0.8, ls="--")
        ax.set_ylim(0, 2.6)
        ax.set_xlim(-5.2, 5.2)
        ax.set_aspect("equal")
        ax.text(-5.0, 2.1, f"t = {time:g} s", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[-1].set_xlabel("x (m): box centres seen from the side; dashed: the region's edge (start + 2 m)", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)


if __name__ == "__main__":
    main(sys.argv[1])
