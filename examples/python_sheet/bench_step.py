#!/usr/bin/python3
"""Milliseconds per LB step of step() through the Python binding, without a fluid
(cosim.time_steps: a uniform stream, A_T = 150): the spring sheet of spring_sheet.py and a
solid that does nothing (the binding's own cost per step: the call and the numpy arrays in
and out). The C++ side is examples/spring_sheet/bench_step.cpp; launch/bench-binding.sh
prints both as the table of docs/solid-library.md.
    bench_step.py [NX NY STEPS]...   (default: 4 6 200 20 20 50)
"""
import sys

import numpy as np

from spring_sheet import SpringSheet, cosim


class NoOp(cosim.Solid):
    def model(self):
        return "no-op"

    def start(self, scene):
        self.x = scene.positions
        self.zero = np.zeros_like(self.x)
        return self.x, scene.areas

    def step(self, step, rho, u):
        return self.x, self.zero


def main(args):
    args = [int(a) for a in args] or [4, 6, 200, 20, 20, 50]
    for k in range(0, len(args) - 2, 3):
        nx, ny, steps = args[k:k + 3]
        scene = cosim.synthetic_scene(nx, ny, 150)
        cosim.time_steps(NoOp(), scene, steps)  # warm-up
        # The best of 5: the machine may be shared, and other processes only ever add time.
        t_none = min(cosim.time_steps(NoOp(), scene, steps * 10) for _ in range(5))
        t_sheet = min(cosim.time_steps(SpringSheet(), scene, steps) for _ in range(5))
        print(f"python {nx * ny} markers: no-op {1e3 * t_none:.6f} ms, spring sheet {1e3 * t_sheet:.6f} ms per LB step")


if __name__ == "__main__":
    main(sys.argv[1:])
