"""Turek & Hron's measure of an oscillating quantity (Turek and Hron 2006): over its last
period, mean = (max + min) / 2, amplitude = (max - min) / 2, and the frequency 1 / period,
the period found between the last two upward crossings of the middle of its range.
Used by launch/turek_hron_study.py and launch/turek_hron_fsi_study.py."""

import argparse

import numpy as np


def last_period(t, v, window):
    """(slice of the last period, frequency) of v over the last `window` seconds of t, or None
    where v did not cross the middle of its range there upward at least twice."""
    m = t >= t[-1] - window
    level = 0.5 * (v[m].min() + v[m].max())
    ups, at = [], []
    for i in np.nonzero(m)[0][1:]:
        if v[i - 1] < level <= v[i]:
            w = (level - v[i - 1]) / (v[i] - v[i - 1])
            ups.append(t[i - 1] + w * (t[i] - t[i - 1]))
            at.append(i)
    if len(ups) < 2:
        return None
    return slice(at[-2], at[-1] + 1), 1.0 / (ups[-1] - ups[-2])


def mean_amplitude(v, s):
    """(mean, amplitude) of v over the slice s: (max + min) / 2, (max - min) / 2."""
    return 0.5 * (v[s].max() + v[s].min()), 0.5 * (v[s].max() - v[s].min())


if __name__ == "__main__":
    argparse.ArgumentParser(description=__doc__.split("\n")[0], epilog=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    print("a module of launch/turek_hron_study.py and launch/turek_hron_fsi_study.py; nothing to run")
