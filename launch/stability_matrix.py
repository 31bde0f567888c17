#!/usr/bin/python3
"""The stability matrix of DESIGN 6 (issue 7 item 2): every case of scenes/stability/ run to its
end, classified from its exit codes, its logs and its HDF5 outputs, and written up as
docs/stability.md with figures. Run it through launch/stability-matrix.sh.

Each case must end either stable (every process exit 0, mass and energy finite and bounded)
or stopped with a diagnosis (a non-zero exit with one line naming the step, the place and
the cause, or a refusal naming the key or the handshake field), and no HDF5 file it leaves
(checkpoints included) may hold a NaN or an infinity. A case that ends otherwise (a crash, a
hang past its time limit, a stop without a diagnosis, a non-finite number in a file) is a
violation: the script exits 1. --short runs the few-second version of each case (the CI
test StabilityMatrixShort).
"""
import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# name, runner, what it stands for in DESIGN 6, the outcome expected (for the table; the
# pass criterion is "stable or stopped with a diagnosis"), the --short overrides, and
# whether the short matrix runs it.
CASES = [
    dict(name='tau_half', runner='fluid', row='tau -> 0.5', expect='stopped',
         short={'run.steps': '600'}),
    dict(name='mach_inlet', runner='fluid', row='Mach above 0.3', expect='stopped (refused)',
         short={}),
    dict(name='mach_local', runner='coupled', row='Mach above 0.3', expect='stopped',
         short={'run.steps': '60'}),
    dict(name='stiff_solid', runner='coupled', row='a solid stiffer than dt_CG allows',
         expect='stopped at the handshake, then stable at the stable A_T (retry)',
         short={'run.steps': '30', 'coupling.rigid_steps': '20'}),
    dict(name='light_sheet', runner='coupled', row='a sheet lighter than the added-mass limit',
         expect='stopped', short={'run.steps': '14', 'coupling.rigid_steps': '10'}),
    dict(name='light_sheet_retry', runner='coupled', row='a sheet lighter than the added-mass limit',
         expect='stopped, then stable at A_T 8000 (retry)',
         short={'run.steps': '16', 'coupling.rigid_steps': '10'}),
    dict(name='light_sheet_implicit', runner='coupled', row='a sheet lighter than the added-mass limit',
         expect='stable (implicit scheme, same A_T)',
         short={'run.steps': '14', 'coupling.rigid_steps': '10'}),
    dict(name='colliding_sheets', runner='coupled', row='colliding sheets (the LJ wall)',
         expect='stable', short={'run.steps': '150'}),
    dict(name='colliding_sheets_stiff', runner='coupled', row='colliding sheets (the LJ wall)',
         expect='stopped; retries do not cure it', short=None),
    dict(name='flutter_30deg', runner='coupled', row='the 30 deg flutter', expect='stable',
         short={'run.steps': '130', 'coupling.rigid_steps': '100'}),
    dict(name='large_deflection', runner='coupled', row='large deflection', expect='stable',
         short={'run.steps': '100'}),
]


def set_key(text, dotted, value):
    """The scene text with [section] key = value set (replaced, or added to the section)."""
    section, key = dotted.split('.', 1)
    header = '[[sheet]]' if section == 'sheet' else '[' + section + ']'
    at = text.find(header + '\n')
    if at < 0:
        return text.rstrip('\n') + '\n\n' + header + '\n' + key + ' = ' + value + '\n'
    end = text.find('\n[', at + 1)
    end = len(text) if end < 0 else end
    body = text[at:end]
    pattern = re.compile(r'^' + re.escape(key) + r'\s*=.*$', re.M)
    body = pattern.sub(key + ' = ' + value, body, count=1) if pattern.search(body) else \
        body.rstrip('\n') + '\n' + key + ' = ' + value + '\n'
    return text[:at] + body + text[end:]


def prepare_scene(case, out, short, cache):
    text = open(os.path.join(ROOT, 'scenes', 'stability', case['name'] + '.toml')).read()
    for k, v in (case['short'] or {}).items() if short else []:
        text = set_key(text, k, v)
    text = set_key(text, 'output.directory', json.dumps(os.path.join(out, case['name'])))
    if case['runner'] == 'coupled':
        text = set_key(text, 'solid.cache_dir', json.dumps(cache))  # the RCGP construction, once
    path = os.path.join(out, 'scenes', case['name'] + '.toml')
    os.makedirs(os.path.dirname(path), exist_ok=True)
    open(path, 'w').write(text)
    return path


def read(path):
    try:
        return open(path, errors='replace').read()
    except OSError:
        return ''


def run_case(case, scene, out, limit_s):
    d = os.path.join(out, case['name'])
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    if case['runner'] == 'fluid':
        cmd = [os.path.join(ROOT, 'build', 'fluid', 'fluid'), scene, '--output', d, '--quiet']
        log = os.path.join(d, 'fluid.log')
    else:
        cmd = ['bash', os.path.join(ROOT, 'launch', 'run-coupled.sh'), scene, '--output', d,
               '--no-build', '--quiet']
        log = os.path.join(d, 'launcher.log')
    start = time.time()
    with open(log, 'w') as f:
        try:
            rc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, timeout=limit_s).returncode
        except subprocess.TimeoutExpired:
            rc = None
    wall = time.time() - start
    if case['runner'] == 'fluid' and rc is not None:
        open(os.path.join(d, 'fluid.exit'), 'w').write('%d\n' % rc)
    return d, rc, wall, ' '.join(cmd)


def nan_scan(d):
    """Every float dataset of every HDF5 file under d: (files, datasets, [non-finite ones])."""
    import h5py
    import numpy as np
    files, sets, bad = 0, 0, []
    for path in sorted(glob.glob(os.path.join(d, '**', '*.h5'), recursive=True)):
        files += 1
        try:
            with h5py.File(path, 'r') as f:
                names = []
                f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
                for n in names:
                    ds = f[n]
                    if ds.dtype.kind != 'f':
                        continue
                    sets += 1
                    if not np.isfinite(ds[()]).all():
                        bad.append(os.path.relpath(path, d) + ':' + n)
        except OSError as e:
            bad.append(os.path.relpath(path, d) + ': unreadable (' + str(e).splitlines()[0] + ')')
    return files, sets, bad


def the_reason(case, d):
    """The one-line reason the run stopped with, or ''."""
    if case['runner'] == 'fluid':
        lines = [l for l in read(os.path.join(d, 'fluid.log')).splitlines() if l.strip()]
        for l in reversed(lines):
            if 'run stopped' in l or ': ' in l and ('.toml:' in l or 'command line' in l):
                return l
        return ''
    for name in ('fluid.log', 'solid.log'):
        for l in read(os.path.join(d, name)).splitlines():
            if 'coupled run stopped:' in l:
                return l.split('coupled run stopped:', 1)[1].strip()
    lines = [l for l in read(os.path.join(d, 'solid.log')).splitlines() if l.startswith('solid: ') and 'step' in l]
    return lines[-1] if lines else ''


def diagnosis_parts(reason):
    """(step, place, cause) named by a reason line; '' for what it does not name."""
    cause = ''
    m = re.search(r'watchdog ([a-z_]+)', reason)
    if m:
        cause = m.group(1)
    elif 'handshake refused' in reason:
        cause = 'handshake refused'
    elif 'unhealthy flow' in reason:
        cause = 'unhealthy flow'
    elif re.search(r'\.toml:\d+: ', reason):
        cause = 'scene refused'
    elif 'non-finite' in reason:
        cause = 'non-finite state'
    m = (re.search(r'watchdog [a-z_]+ at step (\d+)', reason) or re.search(r'after step (\d+)', reason) or
         re.search(r'step (\d+)', reason))
    step = m.group(1) if m else ('start-up' if cause in ('handshake refused', 'scene refused') else '')
    if cause in ('unhealthy flow', 'flow_health'):
        m = re.search(r'cell \(\d+, \d+, \d+\): ([^;]+)', reason)
        if m:
            cause += ' (' + m.group(1).strip() + ')'
    place = ''
    for pat in (r'cell \(\d+, \d+, \d+\)', r'CGPs? \d+ \(sheet \d+, i = \d+, j = \d+\)',
                r'CGPs? \d+ at \([^)]*\)', r'CGPs? \d+', r'dt_CG = [^ ]+ s \(A_T = \d+\)',
                r'[a-z_]+\.[a-z_]+ = [^:]+'):
        m = re.search(pat, reason)
        if m:
            place = m.group(0)
            break
    return step, place, cause


def series(d):
    """Numbers and time series of a run's monitor.h5 and solid.h5 (what exists)."""
    import h5py
    import numpy as np
    r = {}
    try:
        with h5py.File(os.path.join(d, 'monitor.h5'), 'r') as f:
            m, s = f['mass'][()], f['step'][()]
            r['mass_step'], r['mass_drift'] = s.tolist(), (m / m[0] - 1.0).tolist()
            r['max_mach'] = float(np.max(f['max_mach'][()]))
            r['rho_range'] = [float(np.min(f['rho_min'][()])), float(np.max(f['rho_max'][()]))]
    except (OSError, KeyError, IndexError):
        pass
    try:
        with h5py.File(os.path.join(d, 'solid.h5'), 'r') as f:
            e, s = f['total_energy_J'][()], f['step'][()]
            r['energy_step'], r['energy_J'] = s.tolist(), e.tolist()
            w = f['marked_displacement_um'][()]
            r['max_displacement_um'] = float(np.max(np.linalg.norm(w, axis=-1))) if w.size else 0.0
    except (OSError, KeyError, IndexError):
        pass
    # Colliding sheets: the closest CGPs of different sheets over the sheet snapshots.
    closest = None
    for path in sorted(glob.glob(os.path.join(d, 'sheets_*.h5'))):
        with h5py.File(path, 'r') as f:
            x, sh = f['position_um'][()], f['sheet'][()]
        if sh.max() < 1:
            break
        a, b = x[sh == 0], x[sh == 1]
        dist = float(np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)).min())
        closest = dist if closest is None else min(closest, dist)
    if closest is not None:
        r['closest_sheets_um'] = closest
    return r


def classify(case, d, rc, wall, limit_s):
    res = dict(name=case['name'], row=case['row'], expect=case['expect'], runner=case['runner'],
               wall_s=round(wall, 1), launcher_status=rc)
    exits = {}
    for side in ('fluid', 'solid'):
        t = read(os.path.join(d, side + '.exit')).strip()
        if t:
            exits[side] = int(t)
    res['exits'] = exits
    log = read(os.path.join(d, 'fluid.log')) + read(os.path.join(d, 'launcher.log'))
    res['added_mass_warning'] = next((l for l in log.splitlines() if 'warning: added mass' in l), '')
    res['retries'] = [l.split('run-coupled: ', 1)[1] for l in log.splitlines()
                      if l.startswith('run-coupled: watchdog retry') and ': A_T ' in l]
    res['retry_reasons'] = [l.split(': ', 2)[2] for l in log.splitlines()
                            if l.startswith('run-coupled: watchdog retry') and ': A_T ' not in l]
    res['tripped'] = [m.group(0) for m in re.finditer(r'watchdog [a-z_]+ at step \d+', read(os.path.join(d, 'launcher.log')))]
    m = re.search(r'fluid: watchdog: ([0-9.e+-]+) ms per LB step, ([0-9.e+-]+) % of the compute', read(os.path.join(d, 'fluid.log')))
    if m:
        res['watchdog_cost'] = '%s ms per LB step (%s %% of the compute)' % (m.group(1), m.group(2))
    res['margins'] = [l for name in ('fluid.log', 'solid.log') for l in read(os.path.join(d, name)).splitlines()
                      if 'watchdog margins:' in l]
    files, sets, bad = nan_scan(d)
    res['h5_files'], res['h5_float_datasets'], res['non_finite'] = files, sets, bad
    res.update(series(d))
    violations = []
    if rc is None:
        violations.append('no end within %d s (a hang?)' % limit_s)
    elif rc == 0:
        res['outcome'] = 'stable'
        finite = all(abs(v) < float('inf') for v in res.get('energy_J', []) + res.get('mass_drift', []))
        if not finite:
            violations.append('a non-finite energy or mass')
    else:
        reason = the_reason(case, d)
        res['reason'] = reason
        step, place, cause = diagnosis_parts(reason)
        res['step'], res['place'], res['cause'] = step, place, cause
        res['outcome'] = 'stopped'
        if any(code == 1 for code in exits.values()) or rc == 1 or rc > 4:
            violations.append('a system error or a crash (exit %s)' % (exits or rc))
        if not reason:
            violations.append('stopped without a reason')
        elif not (step and place and cause):
            violations.append('the reason does not name the step, the place and the cause: ' + reason)
    if bad:
        violations.append('non-finite values in ' + ', '.join(bad[:5]))
    res['violations'] = violations
    return res


def fmt(v, f='%.3g'):
    return f % v if isinstance(v, (int, float)) else '-'


def figures(results, fig_dir, prefix):
    """One panel per case with data: the sheets' energy (solid.h5, left) and the fluid's mass
    drift (monitor.h5, right) against the LB step; a stopped case's step marked."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    os.makedirs(fig_dir, exist_ok=True)
    shown = [r for r in results if r.get('energy_step') or r.get('mass_step')]
    if not shown:
        return []
    cols = 3
    rows = (len(shown) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.9 * rows), squeeze=False)
    for ax, r in zip(axes.flat, shown):
        if r.get('energy_step'):
            e = [v if v > 0 else float('nan') for v in r['energy_J']]
            ax.semilogy(r['energy_step'], e, color='C0', lw=1.2)
            top = max((v for v in r['energy_J'] if v > 0), default=0.0)
            if top > 0:
                ax.set_ylim(top * 1e-6, top * 3)  # below: the round-off of sheets at rest
        ax.set_ylabel('energy of the sheets (J)', color='C0', fontsize=7)
        ax.tick_params(labelsize=7)
        ax.set_xlabel('LB step', fontsize=7)
        if r.get('mass_step'):
            ax2 = ax.twinx()
            ax2.plot(r['mass_step'], r['mass_drift'], color='C1', lw=1.0, marker='.', ms=2)
            ax2.set_ylabel('mass drift M/M(0) - 1', color='C1', fontsize=7)
            ax2.tick_params(labelsize=7)
        title = r['name'] + ': ' + r.get('outcome', 'no end')
        if r.get('outcome') == 'stopped' and str(r.get('step', '')).isdigit():
            ax.axvline(int(r['step']), color='r', ls='--', lw=0.8)
            title += ' at ' + r['step']
        ax.set_title(title, fontsize=8)
    for ax in list(axes.flat)[len(shown):]:
        ax.axis('off')
    fig.suptitle('Stability matrix: energy of the sheets (blue, solid.h5) and mass drift of the fluid '
                 '(orange, monitor.h5)', fontsize=9)
    fig.tight_layout()
    p = os.path.join(fig_dir, prefix + 'cases.png')
    fig.savefig(p, dpi=100)
    plt.close(fig)
    return [p]


def write_doc(results, doc, figs, command, short, total_wall):
    rel = lambda p: os.path.relpath(p, os.path.dirname(os.path.abspath(doc)))
    L = []
    L.append('# Stability matrix (DESIGN 6)\n')
    L.append('Written by `%s` on this machine (%d cores) in %.0f s; every number below is from that '
             'run. %s\n' % (command, os.cpu_count() or 0, total_wall,
                            'This is the short version (`--short`, the CI test StabilityMatrixShort).' if short else
                            'The short version (`--short`, a few seconds per case) is what the test '
                            '`StabilityMatrixShort` runs.'))
    L.append('Each case is a scene of `scenes/stability/` (its comment says what it does), run through '
             '`launch/run-coupled.sh` (both servers) or the fluid alone. A case must end **stable** (every '
             'process exit 0, the fluid\'s mass and the sheets\' energy finite and bounded) or **stopped** '
             '(a non-zero exit with one line naming the step, the place and the cause, or a refusal naming '
             'the key or the handshake field) before any NaN is written: every HDF5 file a case leaves, '
             'checkpoints and the failed attempts of a retry included, is read back and every float in it '
             'checked finite. The stability watchdog (protocol/README.md section 12) is what stops the '
             'unstable ones.\n')
    L.append('## The cases at a glance\n')
    L.append('| DESIGN 6 row | case | outcome | step | place | cause | numbers | HDF5 checked | wall |')
    L.append('| --- | --- | --- | --- | --- | --- | --- | --- | --- |')
    for r in results:
        nums = []
        if 'mass_drift' in r:
            nums.append('mass drift max %s' % fmt(max(abs(v) for v in r['mass_drift'])))
        if 'max_mach' in r:
            nums.append('Mach max %s' % fmt(r['max_mach']))
        if r.get('energy_J'):
            nums.append('E max %s J' % fmt(max(r['energy_J'])))
        if 'max_displacement_um' in r:
            nums.append('marked CGP moved %s um' % fmt(r['max_displacement_um']))
        if 'closest_sheets_um' in r:
            nums.append('sheets closest %s um' % fmt(r['closest_sheets_um'], '%.4f'))
        outcome = r.get('outcome', 'no end')
        if r['retries']:
            outcome += ' after %d retr%s' % (len(r['retries']), 'y' if len(r['retries']) == 1 else 'ies')
        if r['violations']:
            outcome = '**VIOLATION**: ' + '; '.join(r['violations'])
        L.append('| %s | `%s` | %s | %s | %s | %s | %s | %d files, %d float datasets, %s | %s s |' % (
            r['row'], r['name'], outcome, r.get('step', '-') or '-', (r.get('place') or '-').replace('|', '/'),
            r.get('cause', '-') or '-', '; '.join(nums) or '-', r['h5_files'], r['h5_float_datasets'],
            'all finite' if not r['non_finite'] else '%d NOT finite' % len(r['non_finite']), r['wall_s']))
    L.append('')
    for f in figs:
        L.append('![%s](%s)\n' % (os.path.basename(f), rel(f)))
    by = {r['name']: r for r in results}
    L.append('## What the matrix shows\n')
    L.append('- **Every case ended stable or stopped with a diagnosis, and no file holds a NaN**: %s.' % (
        'true for all %d cases' % len(results) if not any(r['violations'] for r in results) else
        'NOT true for ' + ', '.join(r['name'] for r in results if r['violations'])))
    if 'light_sheet' in by and 'light_sheet_retry' in by:
        L.append('- **The added-mass limit of this scheme is the substeps\' resolution of the fluid\'s '
                 'reaction, not the mass ratio itself.** The solid integrates the momentum-exchange '
                 'force of Eqs. 18-20, -2 rho (U_B - u) dA, held over a substep: explicit Euler for a '
                 'drag with relaxation time T = m / (2 rho_air dA c). A sheet of 200 atoms per CGP has '
                 'm / (rho_air dA dx) = 1.8e-4, 1e4 times lighter than the paper\'s (1.8 for 2e6 atoms '
                 'on dA = dx^2); at A_T = 4000 (dt_CG / T = 2.7) the watchdog stops its first free '
                 'interval within a few substeps (`light_sheet`: %s), at A_T = 8000 (dt_CG / T = 1.4) '
                 'the same sheet runs to the end (`light_sheet_retry`: %s). The start-up warning names '
                 'the A_T at which T spans one substep.' % (
                     by['light_sheet'].get('outcome', '?') + (' at step ' + by['light_sheet'].get('step', '?')),
                     by['light_sheet_retry'].get('outcome', '?')))
    if 'light_sheet' in by and 'light_sheet_implicit' in by:
        L.append('- **The implicit scheme moves that limit** (`[coupling] scheme = "implicit"`, protocol/README.md '
                 '13: the reaction at each substep\'s end velocity, sub-iterations per LB step): the same sheet '
                 'at the same A_T = 4000 (`light_sheet_implicit`: %s). The limit of each scheme against the '
                 'mass ratio is measured in docs/added-mass.md.' % by['light_sheet_implicit'].get('outcome', '?'))
    if 'stiff_solid' in by:
        L.append('- **A solid stiffer than dt_CG allows never starts**: the coordinator refuses the '
                 'handshake and names the smallest stable A_T; with `[watchdog] retry` the launcher '
                 'runs again at that A_T (`stiff_solid`: %s).' % by['stiff_solid'].get('outcome', '?') +
                 (' ' + by['stiff_solid']['retries'][0] if by['stiff_solid']['retries'] else ''))
    if 'colliding_sheets_stiff' in by:
        L.append('- **A retry is not a cure for everything**: with eps = 1e7 eV the Lennard-Jones force '
                 'jumps from 0 to 24 eps / sigma where two CGPs come within sigma (solid/contact/lj_contact.hpp), '
                 'a kick proportional to dt_CG; each retry halves dt_CG and the speed at the trip, but '
                 'the speed stays above the limit (the reasons below), and the run ends stopped.')
    if by.get('flutter_30deg', {}).get('margins'):
        L.append('- **The paper\'s scene stays far from every limit**: the margins of `flutter_30deg` '
                 '(the extremes each sentinel saw, printed at the end of the run): ' +
                 '; '.join('`%s`' % m.split('watchdog margins: ', 1)[1] for m in by['flutter_30deg']['margins']) + '.')
    costs = [(r['name'], r['watchdog_cost']) for r in results if r.get('watchdog_cost')]
    if costs:
        L.append('- **The watchdog\'s cost**, timed by the coordinator in each run that finished (the '
                 'markers, the samples and the flow_health checks of the kernel\'s extrema; '
                 '`fluid: watchdog:` in fluid.log): ' + '; '.join('`%s` %s' % c for c in costs) + '.\n')
    L.append('## The cases\n')
    for r in results:
        L.append('### `%s`: %s\n' % (r['name'], r['row']))
        L.append('Expected: %s. Observed: %s (launcher or fluid status %s, exits %s).\n' % (
            r['expect'], r.get('outcome', 'no end'), r['launcher_status'],
            ', '.join('%s %d' % kv for kv in sorted(r['exits'].items())) or '-'))
        if r['added_mass_warning']:
            L.append('Start-up: `%s`\n' % r['added_mass_warning'])
        for why, t in zip(r['retry_reasons'], r['retries']):
            L.append('- stopped: `%s`' % why.replace('`', "'"))
            L.append('- %s' % t)
        if r['retries']:
            L.append('')
        if r.get('reason'):
            L.append('Reason: `%s`\n' % r['reason'].replace('`', "'"))
        for m in r['margins']:
            L.append('- `%s`' % m)
        if r['margins']:
            L.append('')
        if r['violations']:
            L.append('**Violations**: %s\n' % '; '.join(r['violations']))
    # Paths inside this checkout, relative to it; the failed attempts' folders are not kept.
    text = '\n'.join(L) + '\n'
    text = re.sub(r'; the failed attempt\'s logs are in [^\n`]*', '', text)
    text = text.replace(ROOT + '/', '')
    open(doc, 'w').write(text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--short', action='store_true', help='the few-second version of each case (CI)')
    ap.add_argument('--output', help='folder for the runs (default out/stability or out/stability_short)')
    ap.add_argument('--doc', help='the report (default docs/stability.md, or OUTPUT/stability.md with --short)')
    ap.add_argument('--cases', help='comma-separated case names (default: all of the version)')
    ap.add_argument('--report-only', action='store_true',
                    help='write the report and figures again from OUTPUT/summary.json of the last run, running nothing')
    a = ap.parse_args()
    out = os.path.abspath(a.output or os.path.join(ROOT, 'out', 'stability_short' if a.short else 'stability'))
    doc = os.path.abspath(a.doc or (os.path.join(out, 'stability.md') if a.short else
                                    os.path.join(ROOT, 'docs', 'stability.md')))
    names = [c['name'] for c in CASES]
    wanted = a.cases.split(',') if a.cases else [c['name'] for c in CASES if not a.short or c['short'] is not None]
    for w in wanted:
        if w not in names:
            print('stability-matrix: --cases %s: no case %s; allowed: %s' % (a.cases, w, ', '.join(names)),
                  file=sys.stderr)
            return 2
    for exe in ('fluid/fluid', 'solid/solid'):
        if not os.access(os.path.join(ROOT, 'build', exe), os.X_OK):
            print('stability-matrix: build/%s is missing: build first (bash launch/build.sh)' % exe, file=sys.stderr)
            return 2
    command = 'bash launch/stability-matrix.sh' + (' --short' if a.short else '')
    fig_dir = os.path.join(os.path.dirname(doc), 'figures')
    prefix = 'stability_short_' if a.short else 'stability_'
    if a.report_only:
        summary = os.path.join(out, 'summary.json')
        if not os.path.isfile(summary):
            print('stability-matrix: --report-only: %s: no such file (run the matrix first)' % summary, file=sys.stderr)
            return 2
        data = json.load(open(summary))
        write_doc(data['cases'], doc, figures(data['cases'], fig_dir, prefix), command, a.short, data['wall_s'])
        print('stability-matrix: %s written again from %s' % (doc, summary))
        return 1 if any(r['violations'] for r in data['cases']) else 0
    os.makedirs(out, exist_ok=True)
    cache = os.path.join(out, 'rcgp_cache')
    limit_s = 600 if a.short else 3600
    results, start = [], time.time()
    chosen = [case for case in CASES if case['name'] in wanted]
    for number, case in enumerate(chosen, 1):
        print('stability-matrix: case %d of %d: %s ...' % (number, len(chosen), case['name']), flush=True)
        os.environ['COSIM_RUN_LABEL'] = 'case %d of %d %s' % (number, len(chosen), case['name'])
        scene = prepare_scene(case, out, a.short, cache)
        d, rc, wall, cmd = run_case(case, scene, out, limit_s)
        r = classify(case, d, rc, wall, limit_s)
        r['command'] = cmd
        results.append(r)
        print('stability-matrix: %-24s %-8s %s%s%s (%.1f s)' % (
            case['name'], r.get('outcome', 'no end'),
            ('after %d retries (%s) ' % (len(r['retries']), '; '.join(t.split(': ', 1)[1].split(';')[0] for t in r['retries'])))
            if r['retries'] else '',
            ('step %s, %s: %s' % (r.get('step'), r.get('cause'), r.get('place'))) if r.get('outcome') == 'stopped' else '',
            ('; VIOLATION: ' + '; '.join(r['violations'])) if r['violations'] else '', wall), flush=True)
    total = time.time() - start
    json.dump({'wall_s': total, 'cases': results}, open(os.path.join(out, 'summary.json'), 'w'), indent=1)
    write_doc(results, doc, figures(results, fig_dir, prefix), command, a.short, total)
    bad = [r['name'] for r in results if r['violations']]
    print('stability-matrix: %d cases in %.0f s, %d violation(s)%s; %s, %s' % (
        len(results), total, len(bad), (': ' + ', '.join(bad)) if bad else '', doc,
        os.path.join(out, 'summary.json')))
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main())
