#!/usr/bin/python3
"""A spring-network sheet in Python on the cosim solid library (module `cosim`,
sdk/python/cosim_module.cpp): the physics of examples/spring_sheet/spring_sheet.hpp in
numpy. Point masses m_l = S dA_l on the scene's markers, linear springs to the 8
neighbours, the clamped rows held, the fluid's reaction g dA = 2 rho (U_B - u) dA (Eqs.
18-19) over A_T substeps with the sample frozen; J_l is the mean of g dA over the substeps
(Eq. 24). Lattice units (dx, dt_LB, rho_air).

    bash launch/run-coupled.sh scenes/coupled_spring_sheet.toml \\
        --solid-cmd "/usr/bin/python3 examples/python_sheet/spring_sheet.py --stiffness 0.02"

Options after the scene: --areal-density S (rho_air dx, default 10), --stiffness K (default 0.02).
The module is found in build/sdk/python of this checkout, or wherever PYTHONPATH points
(an installed prefix: PREFIX/lib/python3/dist-packages).
"""
import os
import sys

import numpy as np

try:
    import cosim
except ImportError:
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "build", "sdk", "python"))
    import cosim


class SpringSheet(cosim.Solid):
    def model(self):
        return "spring-sheet-python"

    def start(self, scene):
        density = scene.param("areal-density", 10.0)
        self.k = scene.param("stiffness", 0.02)
        if density <= 0 or self.k <= 0:
            raise ValueError("--areal-density and --stiffness must be > 0")
        self.dt_lb_s = scene.dt_lb_s
        self.time_ratio = scene.time_ratio
        self.x = scene.positions.copy()            # (N, 3)
        self.v = np.zeros_like(self.x)
        self.area = scene.areas.copy()             # (N,)
        self.mass = density * self.area
        held, a, b, first = [], [], [], 0
        for s in scene.sheets:
            idx = first + np.arange(s.nx * s.ny).reshape(s.ny, s.nx)   # idx[j, i]
            held.append(np.arange(s.nx * s.ny) < s.clamped_rows * s.nx)
            for (p, q) in ((idx[:, :-1], idx[:, 1:]), (idx[:-1, :], idx[1:, :]),
                           (idx[:-1, :-1], idx[1:, 1:]), (idx[:-1, 1:], idx[1:, :-1])):
                a.append(p.ravel())
                b.append(q.ravel())
            first += s.nx * s.ny
        self.held = np.concatenate(held)
        self.a, self.b = np.concatenate(a), np.concatenate(b)
        self.rest = np.linalg.norm(self.x[self.b] - self.x[self.a], axis=1)
        self.free = ~self.held
        return self.x.copy(), self.area.copy()

    def spring_forces(self):
        d = self.x[self.b] - self.x[self.a]
        length = np.linalg.norm(d, axis=1)
        t = (self.k * (length - self.rest) / length)[:, None] * d
        f = np.zeros_like(self.x)
        np.add.at(f, self.a, t)
        np.subtract.at(f, self.b, t)
        return f

    def step(self, step, rho, u):
        a_t = self.time_ratio
        dt = 1.0 / a_t
        impulse = np.zeros_like(self.x)
        mean = 0.5 * self.x
        ra = (2.0 * rho * self.area)[:, None]
        inv_m = (dt / self.mass)[:, None]
        for k in range(a_t):
            f = self.spring_forces()
            g = ra * (self.v - u)                  # to the fluid; the marker gets -g
            impulse += g / a_t
            self.v[self.free] += inv_m[self.free] * (f[self.free] - g[self.free])
            self.x[self.free] += dt * self.v[self.free]
            mean += (1.0 if k + 1 < a_t else 0.5) * self.x
        return mean / a_t, impulse

    def energy_lb(self):                          # kinetic + elastic, rho_air dx^3 c^2 (solid.h5, the energy balance)
        stretch = np.linalg.norm(self.x[self.b] - self.x[self.a], axis=1) - self.rest
        return float(0.5 * np.sum(self.mass[:, None] * self.v ** 2) + 0.5 * self.k * np.sum(stretch ** 2))

    def save(self):                                # checkpoints: positions and velocities
        return np.concatenate([self.x.ravel(), self.v.ravel()])

    def restore(self, state):
        state = np.asarray(state, dtype=float)
        if state.size != 2 * self.x.size:
            raise ValueError("a state of another marker count")
        self.x = state[:self.x.size].reshape(-1, 3).copy()
        self.v = state[self.x.size:].reshape(-1, 3).copy()

    def stable_dt_cg_s(self):
        springs = np.bincount(np.concatenate([self.a, self.b]), minlength=len(self.mass))
        w2 = np.max(2.0 * self.k * springs / self.mass)
        return 2.0 / np.sqrt(w2) * self.dt_lb_s if w2 > 0 else float("inf")


if __name__ == "__main__":
    sys.exit(cosim.run(SpringSheet()))
