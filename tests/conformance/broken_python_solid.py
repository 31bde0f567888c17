#!/usr/bin/python3
"""A deliberately broken solid in Python on the solid library for the conformance kit's tests
(tests/integration/test_conformance.cpp): the sheet of examples/python_sheet/spring_sheet.py with one
planted defect chosen by --fault F[,F2...], from LB step --from on (default: every step); the
faults are those of broken_sdk_solid.cpp (none, double, half, over-time-ratio, late, frozen,
end-of-step, reaction-sign, half-reaction, double-reaction, restore-nothing, mis-sized,
with-energy).

    broken_python_solid.py SCENE --fault F [--from STEP] [the library's command line]
"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples", "python_sheet"))
import spring_sheet  # noqa: E402  (the example; it imports cosim)
import cosim  # noqa: E402


def take(option, default):
    """The value of `option VALUE` in sys.argv, removed from it (the library refuses options it was not asked for)."""
    if option in sys.argv:
        k = sys.argv.index(option)
        value = sys.argv[k + 1]
        del sys.argv[k:k + 2]
        return value
    return default


FAULT = take("--fault", "none")
FROM = int(take("--from", "0"))
FAULTS = set(FAULT.split(","))


class BrokenSheet(spring_sheet.SpringSheet):
    def model(self):
        return "broken-python-" + FAULT

    def start(self, scene):
        x, area = super().start(scene)
        self.start_x = x.copy()
        self.previous = None
        return x, area

    def step(self, step, rho, u):
        on = step >= FROM
        if on and "reaction-sign" in FAULTS:   # the marker receives +g dA; J is negated back to g dA
            mean, impulse = super().step(step, -rho, u)
            impulse = -impulse
        elif on and "half-reaction" in FAULTS:  # the marker receives -g dA / 2; J scaled back to g dA
            mean, impulse = super().step(step, 0.5 * rho, u)
            impulse = 2.0 * impulse
        elif on and "double-reaction" in FAULTS:  # the marker receives -2 g dA
            mean, impulse = super().step(step, 2.0 * rho, u)
            impulse = 0.5 * impulse
        else:
            mean, impulse = super().step(step, rho, u)
        computed = impulse.copy()
        if on and "double" in FAULTS:
            impulse = 2.0 * impulse
        if on and "half" in FAULTS:
            impulse = 0.5 * impulse
        if on and "over-time-ratio" in FAULTS:
            impulse = impulse / self.time_ratio
        if on and "late" in FAULTS and self.previous is not None:
            impulse = self.previous
        if on and "frozen" in FAULTS:
            mean = self.start_x.copy()
        if on and "end-of-step" in FAULTS:
            mean = self.x.copy()
        if on and "mis-sized" in FAULTS:
            mean, impulse = mean[:-1], impulse[:-1]
        self.previous = computed
        return mean, impulse

    def energy_lb(self):  # withheld (the kit's own checks meet each fault), unless with-energy
        return super().energy_lb() if "with-energy" in FAULTS else float("nan")

    def restore(self, state):
        if "restore-nothing" not in FAULTS:
            super().restore(state)


if __name__ == "__main__":
    sys.exit(cosim.run(BrokenSheet()))
