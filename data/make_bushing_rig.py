"""Make bushing_rig.csv: a simulated bushing rig's record, written as a lab's logger would.

    fpkbench simulate scenarios/silentblock.toml --set simulation.trajectories=4 \
        --set simulation.record_length=100 --set simulation.seed=7 -o rig.mcap
    fpkbench export rig.mcap --format csv -o rig_export.csv
    python data/make_bushing_rig.py rig_export.csv data/bushing_rig.csv

The export has one row per (instant, trajectory) with SI columns; the rig's table has one
run after the other, runs named "run-1" …, the angle in degrees and every value to five
significant digits (about what a 16-bit logger keeps). Only numpy is used: the table is
made outside fpkbench, as a user's own would be.
"""
import sys

import numpy as np

src, dst = sys.argv[1], sys.argv[2]
raw = np.genfromtxt(src, delimiter=",", names=True)
rows = raw[np.lexsort((raw["t"], raw["trajectory"]))]   # run by run, in time
with open(dst, "w", newline="\n") as f:
    f.write("run,time,angle_deg,omega,alpha,moment\n")
    for r in rows:
        f.write(f"run-{int(r['trajectory']) + 1},{r['t']:.2f},{np.degrees(r['x_j']):.5g},"
                f"{r['v_j']:.5g},{r['a_j']:.5g},{r['p_moment']:.5g}\n")
