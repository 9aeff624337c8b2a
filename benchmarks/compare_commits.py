"""One benchmark at two commits, run in turns, so that a change's cost is measured against
the machine's drift (shared machines here run 30 % slower from one hour to the next).

    .venv/bin/python -m benchmarks.compare_commits --base f7d363b [--runs 2]
        [--out results/collisions/compare.md] -- --spheres 10000 --seconds 12 [--scattered]

Runs `benchmarks.contact_stages` with the arguments after `--`: at the base commit (a git
worktree in a temporary folder, with its own numba cache) and at this checkout, in turns,
`--runs` times each. It tabulates each run's ns per sphere-step at each moment and solver
(contact_stages' stage table), the median of each, and the ratio of this checkout's median
to the base's. Each run is a fresh process; the first step of each compiles or loads its
cache and is not timed.
"""
import argparse
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile

from benchmarks.common import provenance

ROOT = Path(__file__).resolve().parent.parent


def stage_figures(text):
    """{(solver, moment): ns per sphere-step} from contact_stages' stage table."""
    figures, header = {}, None
    for line in text.splitlines():
        cells = [cell.strip() for cell in line.strip().strip('|').split('|')]
        if cells[:2] == ['solver', 'moment']:
            header = cells
        elif header and len(cells) == len(header) and cells[0] and not cells[0].startswith('-'):
            figures[cells[0], cells[1]] = float(cells[header.index('ns per sphere-step')])
        elif header and not line.strip():
            header = None if figures else header
    return figures


def run_stages(tree, arguments, out):
    subprocess.run([sys.executable, '-m', 'benchmarks.contact_stages', *arguments, '--out',
                    str(out)], cwd=tree, check=True, stdout=subprocess.DEVNULL)
    return stage_figures(out.read_text())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--base', required=True, help='the commit to compare against')
    parser.add_argument('--runs', type=int, default=2)
    parser.add_argument('--out', default='results/collisions/compare.md')
    parser.add_argument('stages', nargs=argparse.REMAINDER,
                        help='-- then benchmarks.contact_stages arguments')
    arguments = parser.parse_args()
    stages = [a for a in arguments.stages if a != '--']
    base = subprocess.run(['git', 'rev-parse', '--short', arguments.base], cwd=ROOT,
                          check=True, capture_output=True, text=True).stdout.strip()
    runs = {'base': [], 'this': []}
    with tempfile.TemporaryDirectory() as scratch:
        tree = Path(scratch) / 'base'
        subprocess.run(['git', 'worktree', 'add', '--detach', str(tree), base], cwd=ROOT,
                       check=True, capture_output=True)
        try:
            for turn in range(arguments.runs):
                for name, where in (('base', tree), ('this', ROOT)):
                    out = Path(scratch) / f'{name}-{turn}.md'
                    runs[name].append(run_stages(where, stages, out))
                    print(name, turn, runs[name][-1], flush=True)
        finally:
            subprocess.run(['git', 'worktree', 'remove', '--force', str(tree)], cwd=ROOT,
                           check=False, capture_output=True)
    keys = list(runs['this'][0])
    lines = [provenance(f'.venv/bin/python -m benchmarks.compare_commits --base {base} '
                        f'--runs {arguments.runs} -- {" ".join(stages)}'), '',
             f'benchmarks.contact_stages {" ".join(stages)}: ns per sphere-step, at {base} '
             f'(base) and at this commit, {arguments.runs} runs each in turns (base first)',
             '', '| solver | moment | base runs | this commit runs | base median | '
             'this median | this / base |', '|---|---|---|---|---:|---:|---:|']
    for key in keys:
        before = [figures[key] for figures in runs['base'] if key in figures]
        after = [figures[key] for figures in runs['this']]
        if not before:
            continue
        b, a = statistics.median(before), statistics.median(after)
        lines.append(f'| {key[0]} | {key[1]} | {", ".join(f"{x:g}" for x in before)} | '
                     f'{", ".join(f"{x:g}" for x in after)} | {b:g} | {a:g} | {a / b:.2f} |')
    text = '\n'.join(lines) + '\n'
    out = Path(arguments.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(text)


if __name__ == '__main__':
    main()
