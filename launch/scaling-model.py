#!/usr/bin/python3
"""The strong-scaling model of docs/scaling.md: efficiency of the fluid's z slabs on N ranks.

    /usr/bin/python3 launch/scaling-model.py --rate-mlups R --alpha-us A --beta-gbs B
                                             [--grid NX NY NZ] [--ranks N ...]

Per step a rank updates its slab (the thickest slab sets the pace: ceil(nz / N) planes) at
R MLUPS, then exchanges its halo: 5 populations of one plane (with ghosts and row padding,
fluid/lattice/grid_layout.hpp, double store) to each of its two neighbours, 10 messages of P bytes,
counted one after another (no overlap with the bulk, no concurrency between messages):
T_comm = 10 (A + P / B). Efficiency = T_1 / (N T_N) with T_1 = cells / R. The gather of the
grid to rank 0 for a snapshot is printed apart (19 values per cell through one link at B)."""
import argparse
import math


def row_values(nx, per_line=8):  # GridLayout::row_values of the double store
    return (per_line + nx + 1 + per_line - 1) // per_line * per_line


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rate-mlups", type=float, required=True, help="one rank's update rate")
    ap.add_argument("--alpha-us", type=float, required=True, help="one-way message latency")
    ap.add_argument("--beta-gbs", type=float, required=True, help="message bandwidth, GB/s")
    ap.add_argument("--grid", type=int, nargs=3, default=[240, 120, 180], help="default: 8 x the paper's cells")
    ap.add_argument("--ranks", type=int, nargs="+", default=[2, 16, 64])
    a = ap.parse_args()
    nx, ny, nz = a.grid
    cells = nx * ny * nz
    plane = row_values(nx) * (ny + 2) * 8
    rate = a.rate_mlups * 1e6
    t_comm = 10 * (a.alpha_us * 1e-6 + plane / (a.beta_gbs * 1e9))
    t1 = cells / rate
    print(f"grid {nx} x {ny} x {nz} = {cells} cells; halo message {plane} B, 10 per rank and step "
          f"= {10 * plane} B sent; T_comm = {t_comm * 1e3:.3f} ms; one rank {t1 * 1e3:.1f} ms/step")
    print(f"{'ranks':>6} {'planes':>7} {'T_comp ms':>10} {'T_comm ms':>10} {'efficiency':>11} "
          f"{'overlapped':>11} {'B for E=0.5 GB/s':>17}")
    for n in a.ranks:
        thick = math.ceil(nz / n)
        t_comp = nx * ny * thick / rate
        e = t1 / (n * (t_comp + t_comm))
        e_over = t1 / (n * max(t_comp, t_comm))
        # The bandwidth at which the efficiency falls to 1/2.
        budget = t1 / (n * 0.5) - t_comp - 10 * a.alpha_us * 1e-6
        half = 10 * plane / budget / 1e9 if budget > 0 else float("inf")
        print(f"{n:>6} {thick:>7} {t_comp * 1e3:>10.3f} {t_comm * 1e3:>10.3f} {e:>11.3f} {e_over:>11.3f} {half:>17.2f}")
    gather = 19 * 8 * cells / (a.beta_gbs * 1e9)
    print(f"gather to rank 0 (a snapshot): {19 * 8 * cells / 1e6:.0f} MB, {gather * 1e3:.0f} ms at B")


main()
