#!/usr/bin/python3
"""Combine outputs of `calibration_fit_bench --setup ...` run as separate processes.

Usage: tools/combine_picture_sweeps.py OUT1.txt OUT2.txt ...

The picture sweep is slow (about an hour for 340 runs on two cores), so it is run as several
processes, split by seeds (`--first-seed`) or setups. This prints one markdown table over all
of them, a row per setup and a last row over every module:
- accepted / refused runs and the worst errors are summed or maximised over the files;
- the judged modules' coverage and true/predicted RMS come from the sums each file prints
  after its table, so they are exact: sqrt(sum true^2 / sum predicted^2) over the modules;
- the installed modules' figures are weighted by module count (their sums are not printed).
"""
import re
import sys


def cells(line):
    return [c.strip() for c in line.strip().strip('|').split('|')]


def parse(paths):
    rows, sums, order = {}, {}, []
    for path in paths:
        in_sums = False
        with open(path, encoding='utf-8') as f:
            for line in f:
                if line.startswith("| judged modules' sums"):
                    in_sums = True
                    continue
                if not line.startswith('| ') or line.startswith('| setup') or line.startswith('|---'):
                    continue
                c = cells(line)
                if c[0] == 'all':
                    continue
                if in_sums:
                    s = sums.setdefault(c[0], [0, 0, 0.0, 0.0, 0.0, 0.0])
                    for k in range(6):
                        s[k] += int(c[1 + k]) if k < 2 else float(c[1 + k])
                    continue
                m = re.match(r'([\d.]+)% of (\d+), ([\d.]+) / ([\d.]+)', c[6])
                if not m or len(c) < 11:
                    sys.exit(f'{path}: not a row of calibration_fit_bench --setup: {line.strip()}')
                r = rows.setdefault(c[0], dict(accepted=0, refused=0, installed=[], refusedWorst=0.0,
                                               refusal='', trueWorst=[0.0, 0.0], bound=[0.0, 0.0]))
                if c[0] not in order:
                    order.append(c[0])
                accepted, refused = (int(x) for x in c[2].split('/'))
                r['accepted'] += accepted
                r['refused'] += refused
                r['installed'].append((float(m.group(1)), int(m.group(2)), float(m.group(3)),
                                       float(m.group(4))))
                r['refusedWorst'] = max(r['refusedWorst'], float(c[5]))
                for key, text in (('trueWorst', c[3]), ('bound', c[4])):
                    r[key] = [max(a, float(b)) for a, b in zip(r[key], text.split('/'))]
                if not r['refusal'] and c[10]:
                    r['refusal'] = c[10]
    missing = [name for name in order if name not in sums]
    if missing:
        sys.exit('no sums printed for ' + ', '.join(missing) + ' (a benchmark older than b6a3f91?)')
    return rows, sums, order


def weighted(installed):
    n = sum(x[1] for x in installed)
    if n == 0:
        return ''
    share = sum(x[0] * x[1] for x in installed) / n
    px = (sum(x[2] ** 2 * x[1] for x in installed) / n) ** 0.5
    mm = (sum(x[3] ** 2 * x[1] for x in installed) / n) ** 0.5
    return f'{share:.1f}% of {n}, {px:.2f} / {mm:.2f}'


def judged(s):
    if not s[0]:
        return ''
    px = (s[2] / s[3]) ** 0.5 if s[3] > 0 else 0.0
    mm = (s[4] / s[5]) ** 0.5 if s[5] > 0 else 0.0
    return f'{100.0 * s[1] / s[0]:.1f}% of {s[0]}, {px:.2f} / {mm:.2f}'


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    rows, sums, order = parse(sys.argv[1:])
    print('| setup | accepted / refused | true worst px / mm (accepted) | predicted 3σ worst px / mm '
          '(accepted) | installed: within 3σ, true/pred RMS px / mm (count-weighted) | all judged: '
          'within 3σ, true/pred RMS px / mm | true worst of a refused run | a refusal |')
    print('|---|---|---|---|---|---|---|---|')
    total, accepted, refused, installed = [0, 0, 0.0, 0.0, 0.0, 0.0], 0, 0, []
    for name in order:
        r, s = rows[name], sums[name]
        total = [a + b for a, b in zip(total, s)]
        accepted += r['accepted']
        refused += r['refused']
        installed += r['installed']
        worst = (f"{r['trueWorst'][0]:.3f} / {r['trueWorst'][1]:.2f} | "
                 f"{r['bound'][0]:.3f} / {r['bound'][1]:.2f}") if r['accepted'] else ' | '
        refusedWorst = f"{r['refusedWorst']:.1f} mm" if r['refusedWorst'] > 0 else ''
        print(f"| {name} | {r['accepted']} / {r['refused']} | {worst} | {weighted(r['installed'])} | "
              f"{judged(s)} | {refusedWorst} | {r['refusal']} |")
    print(f'| **all** | {accepted} / {refused} | | | {weighted(installed)} | **{judged(total)}** | | |')


if __name__ == '__main__':
    main()
