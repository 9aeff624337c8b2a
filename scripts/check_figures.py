"""Checks that the figures the docs quote are measured: each is in a results file it links.

    python3 scripts/check_figures.py [FILE.md ...]   (default: README.md and docs/*.md)

Prints `file:line: ...` for each violation and exits 1 when there is one. The rule holds per
block: a paragraph, a list item (with its continuation lines) or a table row; fenced code
blocks are skipped:

1. A figure is a number followed by a unit: ns, µs (or μs, us), ms, s, Hz, kHz, MHz, %,
   MB, kB, GB, MB/s, kB/s, fps, frames/s (a space between them allowed), or × / x as a
   ratio written right after the number (`1.4×`, `3x`). A range `10-20 ms` (or with an en
   dash) quotes both numbers. Numbers in `inline code` and inside link targets are not
   figures.
2. Numbers are normalised by dropping thousands separators: a comma, a space, a no-break
   or thin space between groups of three digits (`1 000` == `1,000` == `1000`). A sign is
   dropped. Then they are compared as written: `26.0` matches `26.0`, `26` matches `26`,
   `26` does not match `26.0` nor `126`.
3. A block that links files under results/ must quote only figures whose number appears
   in at least one of the linked files (every number of a results file counts, normalised
   the same way, and each group of a spaced number on its own too). A link to a results
   file that does not exist is a violation too. A block links a results file by a relative
   markdown link (`[..](results/x.md)` from README.md, `[..](../results/x.md)` from docs/) or by naming
   its path, plain or in `code` (`results/x.md`, `../results/x.md`), resolved from the
   page's folder; a folder (`results/accuracy/`) stands for every text file in it.
4. In docs/performance.md, and in any section whose heading says "figures" (as README's
   "Headline figures"), a block quoting a figure must link a results file.
"""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / 'results'
TEXT_SUFFIXES = {'.md', '.csv', '.json', '.txt', '.yaml', '.yml'}
SEPARATOR = '[,\u00a0\u2009\u202f ]'  # comma, no-break, thin, narrow no-break, space
NUMBER = rf'\d{{1,3}}(?:{SEPARATOR}\d{{3}})+(?:\.\d+)?|\d+(?:\.\d+)?'
SPACED_UNITS = ('frames/s', 'MB/s', 'kB/s', 'fps', 'kHz', 'MHz', 'Hz', 'ns', 'µs', 'μs',
                'us', 'ms', 'MB', 'kB', 'GB', '%', 's')
FIGURE = re.compile(
    rf'(?<![\w.]) ({NUMBER}) (?:\s*[-–]\s*({NUMBER}))?'
    rf'(?: [\u00a0\u2009\u202f ]? (?:{"|".join(map(re.escape, SPACED_UNITS))}) | [×x] )'
    r'(?!\w)', re.VERBOSE)
ANY_NUMBER = re.compile(rf'(?<![\d])({NUMBER})')
LINK = re.compile(r'\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)')
CODE_SPAN = re.compile(r'`[^`]*`')
PATH_MENTION = re.compile(r'(?<![\w/.])((?:\.\./)*results/[\w./-]*[\w/])')
HEADING = re.compile(r'^(#{1,6})\s+(.*)')


def normalised(number: str) -> str:
    return re.sub(SEPARATOR, '', number)


def figures(line: str) -> list:
    """(number as written, normalised) of every figure the line quotes."""
    text = LINK.sub('](', CODE_SPAN.sub('', line))
    found = []
    for match in FIGURE.finditer(text):
        found += [(n, normalised(n)) for n in match.groups() if n]
    return found


def numbers_in(path: Path) -> set:
    """Every number of a results file, normalised, and each group of a spaced one alone."""
    try:
        text = path.read_text(encoding='utf-8')
    except (UnicodeDecodeError, OSError):
        return set()
    found = set()
    for number in ANY_NUMBER.findall(text):
        found.add(normalised(number))
        found.update(re.split(SEPARATOR, number))
    return found


def results_links(line: str, page: Path) -> list:
    """The paths under results/ the line links or names, each once."""
    linked = []
    for target in LINK.findall(line) + PATH_MENTION.findall(line):
        if '://' in target or target.startswith(('#', 'mailto:')):
            continue
        path = (page.parent / target.split('#')[0].split('?')[0]).resolve()
        if (path == RESULTS or RESULTS in path.parents) and path not in linked:
            linked.append(path)
    return linked


def linked_numbers(paths: list) -> set:
    found = set()
    for path in paths:
        files = sorted(path.rglob('*')) if path.is_dir() else [path]
        for file in files:
            if file.is_file() and file.suffix in TEXT_SUFFIXES:
                found |= numbers_in(file)
    return found


LIST_ITEM = re.compile(r'^\s*(?:[-*+]|\d+\.)\s')


def blocks(text: str):
    """(first line number, text) of each paragraph, list item and table row outside fenced
    code, and (line number, heading line) of each heading: a figure and the results link
    it comes from may sit on different lines of one paragraph or item."""
    fenced, start, lines = False, None, []
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith(('```', '~~~')):
            fenced = not fenced
            line = ''
        elif fenced:
            continue
        new_block = (not line.strip() or HEADING.match(line) or LIST_ITEM.match(line)
                     or line.lstrip().startswith('|'))
        if new_block and lines:
            yield start, ' '.join(lines)
            lines = []
        if HEADING.match(line):
            yield number, line
        elif line.strip():
            if not lines:
                start = number
            lines.append(line.strip())
    if lines:
        yield start, ' '.join(lines)


def violations(page: Path) -> list:
    """'file:line: what' for every paragraph, item or row of `page` that breaks the rule
    (its first line's number)."""
    shown = page.relative_to(ROOT) if ROOT in page.resolve().parents else page
    must_link = page.name == 'performance.md' and page.parent.name == 'docs'
    figures_level, found = None, []
    for number, block in blocks(page.read_text(encoding='utf-8')):
        heading = HEADING.match(block)
        if heading:
            level = len(heading.group(1))
            if 'figures' in heading.group(2).lower():
                figures_level = level
            elif figures_level is not None and level <= figures_level:
                figures_level = None
            continue
        quoted = figures(block)
        if not quoted:
            continue
        where = f'{shown}:{number}'
        linked = results_links(block, page)
        if not linked:
            if must_link or figures_level is not None:
                found += [f'{where}: {written!r} quoted with no results/ link'
                          for written, _ in quoted]
            continue
        missing = [path for path in linked if not path.exists()]
        found += [f'{where}: links {path.relative_to(ROOT)}, which does not exist'
                  for path in missing]
        measured = linked_numbers([path for path in linked if path.exists()])
        names = ', '.join(str(path.relative_to(ROOT)) for path in linked)
        found += [f'{where}: {written!r} is in none of {names}'
                  for written, plain in quoted if plain not in measured]
    return found


def default_pages() -> list:
    pages = [ROOT / 'README.md', *sorted((ROOT / 'docs').glob('*.md'))]
    return [page for page in pages if page.is_file()]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    pages = [Path(arg).resolve() for arg in argv] or default_pages()
    found = [violation for page in pages for violation in violations(page)]
    for violation in found:
        print(violation)
    if found:
        print(f'{len(found)} figure(s) without a measured source', file=sys.stderr)
    return 1 if found else 0


if __name__ == '__main__':
    sys.exit(main())
