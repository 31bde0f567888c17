#!/usr/bin/env python3
"""Writes the paper's coupled scenes (Inoue et al. 2010, section 3) into scenes/paper/.

    python3 launch/paper-scenes.py          # rewrites scenes/paper/*.toml

Single graphene: angle of attack 0, 30, 45, 60, 90 deg at Re 40, and Re 1, 10, 20 at
90 deg; a pair parallel to the flow at Re 40 with span-wise gaps ds = 1.02, 2.05, 4.10,
8.20, 11.5 um. Each at the paper's size (120 x 60 x 90, dx = 0.2561 um, 15000 rigid LB steps,
then 15000 free for a single sheet, 30000 or 60000 for a pair) and as a reduced preset
(half the resolution, the same physical box and Mach number, the same physical times, except
that a pair's free phase is cut to the single sheet's 6.7 us: two sheets cost twice the solid
time, and the paper's 13.4 or 26.8 us after release are two or four times as many steps). The sheet: 5 x 40 CGPs of 2e6 carbon atoms, W 1.2 um x H 8.8 um
(CGP spacing 0.24 x 0.22 um, graphene's areal density), clamped on the plate, its base
(middle of the bottom row) a quarter of the channel downstream of the inlet and mid-span
(the paper's Fig. 4 shows the layout but gives no coordinates: a choice, see
docs/reproduction.md). Re = U_max H / nu sets tau (Eq. 13). The solid model is the
corotational variant of the RCGP sheet: at Re 40 the sheet bends by several micrometres,
which the linear model misreads as stretching (its tip runs out of the channel).
"""
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "scenes" / "paper"
DX_UM = 0.2561                       # Table 1
GRID = (120, 60, 90)
U_MAX = {1: 0.00260, 10: 0.0260, 20: 0.0519, 40: 0.104}  # U_max / c (section 3.1)
RIGID_STEPS = 15000                  # 6.7 us of spin-up at the paper's dt
H_UM, W_UM = 8.8, 1.2


def scene(name, description, re, sheets, free_steps, reduced, extra_comment=""):
    f = 2 if reduced else 1
    reduced_note = " (reduced preset: half resolution, same physics and times)"
    if reduced and len(sheets) > 1:
        reduced_note = " (reduced preset: half resolution, same physics, free phase 6.7 us)"
    nx, ny, nz = (g // f for g in GRID)
    dx = DX_UM * f
    rigid = RIGID_STEPS // f
    steps = rigid + free_steps // f
    lines = [
        f"# {description}" + (reduced_note if reduced else ""),
        "# Written by launch/paper-scenes.py; regenerate rather than edit.",
        f"#   bash launch/run-coupled.sh scenes/paper/{name}.toml",
    ]
    if extra_comment:
        lines.append(f"# {extra_comment}")
    lines += [
        "",
        "[scene]",
        f'name = "{name}"',
        f'description = "{description}"',
        "",
        "[grid]",
        f"nx = {nx}",
        f"ny = {ny}",
        f"nz = {nz}",
        f"dx_um = {dx:.4f}",
        "",
        "[fluid]",
        f"reynolds = {re}",
        f"reference_length_um = {H_UM}    # H, the sheet height",
        "",
        "[inlet]",
        f"u_max = {U_MAX[re]}",
        'profile = "blasius"',
        f"boundary_layer_um = {0.1 * H_UM:.2f}   # uniform above y = 0.1 H",
        "",
        "[boundaries]",
        'x_min = "inlet"',
        'x_max = "outflow"',
        'y_min = "wall"',
        'y_max = "free_slip"',
        'z_min = "periodic"',
        'z_max = "periodic"',
        "",
        "[run]",
        f"steps = {steps}",
        f"monitor_every = {100 // f}     # health check; also refreshes U_b for C_D, C_L",
        "",
        "[output]",
        f'directory = "out/{name}"',
        "fields_every = 0                 # whole-grid snapshots are large; ask for them if needed",
        f"planes_every = {1000 // f}             # vorticity on y = L/2 and L/3 (Figs. 9, 12)",
        "planes_y = [0.5, 0.3333]",
        f"sheets_every = {250 // f}             # CGP positions and strain (Fig. 11)",
        "",
        "[coupling]",
        "time_ratio = 150",
        f"rigid_steps = {rigid}",
        "",
        "[solid]",
        'model = "corotational"   # large deflection: the linear rcgp model reads the deep bending at Re 40 as stretching',
        'flexural_scaling = "paper"',
        "stages = 9",
    ]
    for base, theta in sheets:
        lines += [
            "",
            "[[sheet]]",
            "nx_cg = 5",
            "ny_cg = 40",
            f"spacing_um = [{W_UM / 5:.2f}, {H_UM / 40:.2f}]   # W / 5, H / 40",
            "atoms_per_cgp = 2e6",
            f"base_um = [{base[0]:.4f}, 0.0, {base[1]:.4f}]",
            f"theta_deg = {theta}",
        ]
    (OUT / f"{name}.toml").write_text("\n".join(lines) + "\n")


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    for old in OUT.glob("*.toml"):
        old.unlink()
    length_x, length_z = GRID[0] * DX_UM, GRID[2] * DX_UM
    centre = (length_x / 4, length_z / 2)
    for reduced in (False, True):
        tag = "_reduced" if reduced else ""
        for theta in (0, 30, 45, 60, 90):
            scene(f"single_theta{theta:02d}_re40{tag}",
                  f"single graphene, angle of attack {theta} deg, Re 40", 40,
                  [(centre, theta)], 15000, reduced)
        for re in (1, 10, 20):
            scene(f"single_theta90_re{re:02d}{tag}",
                  f"single graphene, angle of attack 90 deg, Re {re}", re,
                  [(centre, 90)], 15000, reduced)
        for ds in (1.02, 2.05, 4.10, 8.20, 11.5):
            free = 60000 if ds in (4.10, 8.20) else 30000
            if reduced:
                free = 15000   # the single sheet's 6.7 us after release (see the docstring)
            half = ds / 2
            sheets = [((centre[0], centre[1] - half), 0), ((centre[0], centre[1] + half), 0)]
            note = ("ds = 11.5 um in a 23 um span is a periodic array (the paper notes it)"
                    if ds == 11.5 else "")
            scene(f"pair_ds{ds:05.2f}_re40{tag}".replace(".", "p"),
                  f"pair of graphenes parallel to the flow, ds = {ds} um, Re 40", 40,
                  sheets, free, reduced, note)


if __name__ == "__main__":
    import argparse
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    main()
