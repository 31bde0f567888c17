#!/usr/bin/python3
"""The strong-scaling model of docs/scaling.md: efficiency of the fluid's blocks on N ranks.

    /usr/bin/python3 launch/scaling-model.py --rate-mlups R --alpha-us A --beta-gbs B
                                             [--grid NX NY NZ] [--ranks N ...]
                                             [--layout slabs|blocks]

Per step a rank updates its block (the largest block sets the pace) at R MLUPS, then exchanges
its halo, one message per population and neighbour (fluid/mpi/'s exchange; counted one after
another: no overlap with the bulk, no concurrency between messages; with ghosts and row
padding, fluid/lattice/grid_layout.hpp, double store):
- slabs (z only, N x 1): the 5 populations that cross a z face, one plane of nx x (ny + 2)
  cells each, to each of the two z neighbours: 10 messages;
- blocks (a py x pz process grid, y and z): the 5 populations of each y face (nx x (nz_b + 2)
  cells) and of each z face (nx x (ny_b + 2) cells) to the (up to) 4 face neighbours, and the
  one D3Q19 population (0, +-1, +-1) that crosses each of the 4 y-z edges (a row of nx) to the
  4 edge neighbours: 24 messages. Of the process grids py x pz = N the model takes the one with
  the least halo bytes per rank (ties: more ranks along z).
T_comm = sum over messages (A + P / B). Efficiency = T_1 / (N T_N) with T_1 = cells / R;
"overlapped" is the bound if the exchange were hidden behind the bulk: T_1 / (N max(T_comp,
T_comm)). The gather of the grid to rank 0 for a snapshot (before parallel HDF5) is printed
apart (19 values per cell through one link at B)."""
import argparse
import math


def row_values(nx, per_line=8):  # GridLayout::row_values of the double store
    return (per_line + nx + 1 + per_line - 1) // per_line * per_line


def slab_messages(nx, ny, nz, n):
    """(block cells, [message bytes]) of the thickest z slab on n ranks, or None if n > nz."""
    if n > nz:
        return None
    thick = math.ceil(nz / n)
    plane = row_values(nx) * (ny + 2) * 8
    return nx * ny * thick, [plane] * (10 if n > 1 else 0), (1, n)


def block_messages(nx, ny, nz, py, pz):
    """(block cells, [message bytes]) of the largest block of a py x pz process grid."""
    if py > ny or pz > nz:
        return None
    by, bz = math.ceil(ny / py), math.ceil(nz / pz)
    row = row_values(nx) * 8
    msgs = []
    if pz > 1:
        msgs += [row * (by + 2)] * 10   # z faces: 5 populations x 2 neighbours
    if py > 1:
        msgs += [row * (bz + 2)] * 10   # y faces
    if py > 1 and pz > 1:
        msgs += [row] * 4               # y-z edges: one population each
    return nx * by * bz, msgs, (py, pz)


def best_blocks(nx, ny, nz, n):
    best = None
    for py in range(1, n + 1):
        if n % py:
            continue
        m = block_messages(nx, ny, nz, py, n // py)
        if m is None:
            continue
        key = (sum(m[1]), m[0], py)
        if best is None or key < best[0]:
            best = (key, m)
    return best[1] if best else None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rate-mlups", type=float, required=True, help="one rank's update rate")
    ap.add_argument("--alpha-us", type=float, required=True, help="one-way message latency")
    ap.add_argument("--beta-gbs", type=float, required=True, help="message bandwidth, GB/s")
    ap.add_argument("--grid", type=int, nargs=3, default=[240, 120, 180], help="default: 8 x the paper's cells")
    ap.add_argument("--ranks", type=int, nargs="+", default=[2, 16, 64])
    ap.add_argument("--layout", choices=("slabs", "blocks"), default="slabs",
                    help="z slabs (the default) or a 2D process grid in y and z")
    a = ap.parse_args()
    for name, v in (("--rate-mlups", a.rate_mlups), ("--alpha-us", a.alpha_us), ("--beta-gbs", a.beta_gbs)):
        if not v > 0 or not math.isfinite(v):
            ap.error(f"{name} = {v}: allowed: a finite number > 0")
    if min(a.grid) < 1 or min(a.ranks) < 1:
        ap.error(f"--grid {a.grid} --ranks {a.ranks}: allowed: integers >= 1")
    nx, ny, nz = a.grid
    cells = nx * ny * nz
    rate = a.rate_mlups * 1e6
    alpha, beta = a.alpha_us * 1e-6, a.beta_gbs * 1e9
    t1 = cells / rate
    print(f"grid {nx} x {ny} x {nz} = {cells} cells, {a.layout}; one rank {t1 * 1e3:.1f} ms/step")
    print(f"{'ranks':>6} {'py x pz':>8} {'block':>12} {'messages':>9} {'bytes sent':>11} {'T_comp ms':>10} "
          f"{'T_comm ms':>10} {'efficiency':>11} {'overlapped':>11} {'B for E=0.5 GB/s':>17}")
    for n in a.ranks:
        m = slab_messages(nx, ny, nz, n) if a.layout == "slabs" else best_blocks(nx, ny, nz, n)
        if m is None:
            print(f"{n:>6}  no {a.layout} of at least one cell each on this grid")
            continue
        block_cells, msgs, (py, pz) = m
        by, bz = math.ceil(ny / py), math.ceil(nz / pz)
        t_comp = block_cells / rate
        t_comm = len(msgs) * alpha + sum(msgs) / beta
        e = t1 / (n * (t_comp + t_comm))
        e_over = t1 / (n * max(t_comp, t_comm))
        # The bandwidth at which the efficiency falls to 1/2.
        budget = t1 / (n * 0.5) - t_comp - len(msgs) * alpha
        half = sum(msgs) / budget / 1e9 if budget > 0 else float("inf")
        print(f"{n:>6} {f'{py} x {pz}':>8} {f'{nx}x{by}x{bz}':>12} {len(msgs):>9} {sum(msgs):>11} {t_comp * 1e3:>10.3f} "
              f"{t_comm * 1e3:>10.3f} {e:>11.3f} {e_over:>11.3f} {half:>17.2f}")
    gather = 19 * 8 * cells / beta
    print(f"gather to rank 0 (a snapshot before parallel HDF5): {19 * 8 * cells / 1e6:.0f} MB, {gather * 1e3:.0f} ms at B")


main()
