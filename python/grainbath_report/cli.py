"""Command line: locate the output, run every applicable section, write report.md / report.html."""
import argparse
import datetime
import os
import re
import sys
import traceback


def _fail(msg, code=2):
    print(f"grainbath report: error: {msg}", file=sys.stderr)
    return code


# Names the files a report wrote into its directory, so that the next report there removes
# exactly those (stale plots of sections that no longer apply) and nothing of the user's.
MARKER = ".grainbath-report"


def _own_files(report_dir):
    """The files an earlier report wrote in report_dir, or None if it is not a report directory.
    Reports written before the marker (2026-12-06) are recognised by report.md's title; their
    plots are the PNGs report.md shows."""
    marker = os.path.join(report_dir, MARKER)
    if os.path.isfile(marker):
        with open(marker, encoding="utf-8") as f:
            return [MARKER] + [line.strip() for line in f if line.strip()]
    try:
        with open(os.path.join(report_dir, "report.md"), encoding="utf-8") as f:
            text = f.read()
    except (OSError, ValueError):
        return None
    if not text.startswith("# grainbath "):
        return None
    return ["report.md", "report.html"] + re.findall(r"\]\(([^()/\s]+\.png)\)", text)


def _prepare_report_dir(report_dir):
    """Creates report_dir, or empties it of an earlier report's files. A directory holding other
    files is refused (they are the user's: --out takes a new or empty directory, or one a report
    wrote). Returns an error message, or None."""
    if os.path.lexists(report_dir) and not os.path.isdir(report_dir):
        return f"{report_dir}: not a directory (--out takes a new or empty directory, or one a report wrote)"
    try:
        os.makedirs(report_dir, exist_ok=True)
        entries = os.listdir(report_dir)
        if not entries:
            return None
        own = _own_files(report_dir)
        if own is None:
            shown = ", ".join(sorted(entries)[:3]) + (", ..." if len(entries) > 3 else "")
            return (f"{report_dir}: holds files no report wrote ({shown}); --out takes a new or empty "
                    f"directory, or one a report wrote, so that nothing of yours is replaced or removed")
        for name in own:
            path = os.path.join(report_dir, name)
            if os.sep not in name and name not in (".", "..") and os.path.isfile(path) and not os.path.islink(path):
                os.remove(path)
    except OSError as e:
        return f"{report_dir}: cannot create the report directory ({e})"
    return None


def _write_marker(report_dir, ctx):
    names = [os.path.basename(p) for p in ctx.saved] + ["report.md", "report.html"]
    with open(os.path.join(report_dir, MARKER), "w", encoding="utf-8") as f:
        f.write("".join(n + "\n" for n in names))


def _context(report_dir):
    """The plotting context, with the marker kept up to date as each plot is saved: a report
    that stops half-way (a failed section with --strict, an error) still leaves a directory
    the next report recognises as its own."""
    from .plotting import Context
    ctx = Context(report_dir)
    _write_marker(report_dir, ctx)
    save = ctx.save

    def save_and_list(fig, name):
        path = save(fig, name)
        with open(os.path.join(report_dir, MARKER), "a", encoding="utf-8") as f:
            f.write(os.path.basename(path) + "\n")
        return path

    ctx.save = save_and_list
    return ctx


def main(argv):
    ap = argparse.ArgumentParser(prog="grainbath report",
                                 description="Plots and report.md/report.html from a grainbath run's output.")
    ap.add_argument("dir", help="case directory (uses DIR/output) or output directory with results.h5 + summary.json")
    ap.add_argument("--out", help="report directory (default: OUTPUT_DIR/report)")
    ap.add_argument("--strict", action="store_true",
                    help="fail when any section fails (default: note the failure in the report and go on); "
                         "also enabled by GRAINBATH_REPORT_STRICT=1")
    ap.add_argument("--x", metavar="KEY",
                    help="sweep report: the swept key to plot against (default: the numeric swept key with the "
                         "most values; docs/OUTPUT.md, \"Sweep directories\")")
    args = ap.parse_args(argv)
    strict = args.strict or os.environ.get("GRAINBATH_REPORT_STRICT", "") not in ("", "0")

    try:
        import numpy  # noqa: F401
        import matplotlib  # noqa: F401
        import h5py  # noqa: F401
    except ImportError as e:
        return _fail(f"{sys.executable} lacks {e.name}; install python3-matplotlib and python3-h5py "
                     f"(Debian/Ubuntu: apt-get install python3-matplotlib python3-h5py)", 3)

    from .data import ReportError, RunData, locate_output
    from .document import write_html, write_markdown
    from .sections import SECTIONS

    from .sweep import discover
    try:
        out_dir = locate_output(args.dir)
    except ReportError as e:
        runs = discover(os.path.abspath(args.dir)) if os.path.isdir(args.dir) else []
        if len(runs) >= 2:
            return sweep_report(os.path.abspath(args.dir), runs, args.out, args.x)
        if len(runs) == 1:
            out_dir = runs[0]
        else:
            return _fail(str(e))
    if args.x is not None:
        return _fail(f"--x {args.x}: {args.dir} holds one run, not a sweep; --x chooses the x axis of a sweep report")
    try:
        run = RunData(out_dir)
    except ReportError as e:
        return _fail(str(e))

    report_dir = os.path.abspath(args.out) if args.out else os.path.join(out_dir, "report")
    problem = _prepare_report_dir(report_dir)  # stale plots of an earlier report go, nothing else
    if problem:
        run.close()
        return _fail(problem)

    try:
        ctx = _context(report_dir)
    except OSError as e:
        run.close()
        return _fail(f"{report_dir}: cannot write the report ({e})")
    sections, failures = [], []
    for fn in SECTIONS:
        try:
            s = fn(run, ctx)
        except Exception as e:  # one broken section must not cost the whole report
            if strict:
                traceback.print_exc()
                return _fail(f"section {fn.__module__}.{fn.__name__} failed: {e}", 1)
            failures.append(f"{fn.__module__.split('.')[-1]}.{fn.__name__}: {type(e).__name__}: {e}")
            print(f"grainbath report: warning: section {fn.__name__} failed ({type(e).__name__}: {e}); "
                  f"left out", file=sys.stderr)
            continue
        if s is not None:
            sections.append(s)
    if failures:
        from .document import Section
        s = Section("Sections that failed", "failures")
        s.text("These sections raised an error and are missing from the report (please report it):\n\n" +
               "\n".join(f"- `{f}`" for f in failures))
        sections.insert(1, s)

    case_name = os.path.basename(os.path.dirname(out_dir)) if os.path.basename(out_dir) == "output" \
        else os.path.basename(out_dir)
    title = f"grainbath report: {case_name} ({run.solver})"
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    intro = (f"Output directory `{out_dir}`; report made {now} from `results.h5` and `summary.json`. "
             f"In every plot the simulation is black (line or points) and each theory has its own colour and "
             f"line style. The data layout is documented in docs/OUTPUT.md.")
    base = os.path.abspath(args.dir)
    sweep_dir = os.path.join(base, "sweep")
    if os.path.isdir(sweep_dir):
        n_sweep = len(discover(sweep_dir))
        if n_sweep:
            intro += (f" This case also has a sweep of {n_sweep} runs: `grainbath report {sweep_dir}` "
                      f"compares them.")
    md = os.path.join(report_dir, "report.md")
    htm = os.path.join(report_dir, "report.html")
    try:
        write_markdown(md, title, intro, sections)
        write_html(htm, title, intro, sections)
        _write_marker(report_dir, ctx)
    except OSError as e:
        return _fail(f"{report_dir}: cannot write the report ({e})")
    finally:
        run.close()
    print(f"report: {htm}  ({len(ctx.saved)} plots, {len(sections)} sections; also report.md)")
    return 1 if (failures and strict) else 0


def sweep_report(base, runs, out, x=None):
    """Report over several runs found below `base`, plotted against the swept key `x` (None: the
    rule of axes.choose_x)."""
    from .data import ReportError
    from .document import write_html, write_markdown
    from .sweep import build

    report_dir = os.path.abspath(out) if out else os.path.join(base, "report")
    if x is not None:  # a --x that is no swept key is refused before anything is written
        from .axes import choose_x
        from .data import RunData
        from .sweep import sweep_axes
        try:
            found = [RunData(p) for p in runs]
        except ReportError as e:
            return _fail(str(e))
        keys = sweep_axes(found, base)
        try:
            choose_x({k: [r.params.get(k) for r in found] for k in keys}, x)
        except ValueError as e:
            return _fail(str(e))
        finally:
            for r in found:
                r.close()
    problem = _prepare_report_dir(report_dir)
    if problem:
        return _fail(problem)
    try:
        ctx = _context(report_dir)
    except OSError as e:
        return _fail(f"{report_dir}: cannot write the report ({e})")
    try:
        sections = build(runs, ctx, x=x, base=base)
    except ReportError as e:
        return _fail(str(e))
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    title = f"grainbath sweep report: {os.path.basename(base.rstrip('/'))} ({len(runs)} runs)"
    intro = (f"Runs found below `{base}`; report made {now}. Simulation in black, theory in colour; "
             f"the data layout is documented in docs/OUTPUT.md.")
    try:
        write_markdown(os.path.join(report_dir, "report.md"), title, intro, sections)
        write_html(os.path.join(report_dir, "report.html"), title, intro, sections)
        _write_marker(report_dir, ctx)
    except OSError as e:
        return _fail(f"{report_dir}: cannot write the report ({e})")
    print(f"report: {os.path.join(report_dir, 'report.html')}  (sweep of {len(runs)} runs, {len(ctx.saved)} plots; "
          f"also report.md)")
    return 0
