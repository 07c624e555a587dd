"""Progress reporting: tqdm bars and messages on standard error.

The one home of what the estimators print while they work, driven by their
``verbose`` parameter:

* ``verbose=0``: nothing at all is printed (warnings still go through
  :mod:`warnings`);
* ``verbose=1``: a `tqdm <https://tqdm.github.io>`_ progress bar for each
  long step (simulator runs, emulator restarts, module-2 restarts, MCMC
  draws, the designer's phases) and one line per finished step (the
  module summaries), prefixed with the estimator's name;
* ``verbose=2``: also detail lines (each restart's log-likelihood, each
  chain's end of burn-in and of its draws, each chunk of the designer's
  search).

Everything goes to ``sys.stderr`` as it is at the time of writing (so that
a redirection or pytest's ``capsys`` sees it); standard output stays the
user's. Lines are written with :meth:`tqdm.tqdm.write`, so they do not break
a bar that is being drawn. The numerical code receives a :class:`Progress`
(or None, silent) as an argument and never prints by itself: the work in
joblib workers reports to the parent process by returning, and the parent
updates the bar (:func:`results_as_ready`).

Examples
--------
>>> import sys
>>> from contextlib import redirect_stderr
>>> from skmba._core.progress import Progress
>>> progress = Progress(verbose=2, name="Example")
>>> with redirect_stderr(sys.stdout):  # (to show the lines here)
...     progress.info("module 1 done")
...     progress.detail("restart 1 of 3: log-likelihood 12.5")
...     with Progress(verbose=0).bar(10, "runs") as bar:  # silent
...         bar.update(10)
[Example] module 1 done
[Example] restart 1 of 3: log-likelihood 12.5
"""

import sys

from joblib import Parallel
from tqdm import tqdm

#: Detail lines from this ``verbose`` on; bars and step lines from 1.
DETAIL = 2


class _SilentBar:
    """The do-nothing stand-in of a tqdm bar (``verbose=0``)."""

    def __init__(self, total=None):
        self.n, self.total = 0, total

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n=1):
        self.n += n

    def set_postfix_str(self, s="", refresh=True):
        pass

    def refresh(self):
        pass

    def close(self):
        pass


class Progress:
    """Progress bars and messages of one estimator, on standard error.

    Parameters
    ----------
    verbose : int, default=0
        0 prints nothing, 1 bars and one line per finished step, 2 also
        detail lines.
    name : str, default=None
        Prefix of every line and bar, as ``[name] message``.

    Examples
    --------
    >>> Progress(1, "ModularBayesCalibrator").enabled
    True
    >>> Progress().enabled, Progress(1).details
    (False, False)
    """

    def __init__(self, verbose=0, name=None):
        self.verbose = int(verbose)
        self.name = name

    @property
    def enabled(self):
        """Whether bars (and step lines) are shown: ``verbose >= 1``."""
        return self.verbose >= 1

    @property
    def details(self):
        """Whether detail lines are shown: ``verbose >= 2``."""
        return self.verbose >= DETAIL

    def _text(self, message):
        return message if self.name is None else f"[{self.name}] {message}"

    def info(self, message):
        """A line about a finished step (``verbose >= 1``)."""
        if self.enabled:
            tqdm.write(self._text(message), file=sys.stderr)

    def detail(self, message):
        """A detail line (``verbose >= 2``)."""
        if self.details:
            tqdm.write(self._text(message), file=sys.stderr)

    def bar(self, total, desc, unit="it"):
        """A tqdm bar on ``sys.stderr`` (a silent stand-in at ``verbose=0``).

        Use it as a context manager and call ``update(n)`` as work is done;
        ``total`` may be raised on the way (``bar.total += n``).

        Examples
        --------
        >>> with Progress(0).bar(3, "tasks") as bar:
        ...     bar.update(3)
        >>> bar.n
        3
        """
        if not self.enabled:
            return _SilentBar(total)
        return tqdm(
            total=total,
            desc=self._text(desc),
            unit=unit,
            file=sys.stderr,
            leave=True,
            dynamic_ncols=True,
        )


#: The progress of code called without one: silent.
SILENT = Progress(0)


def as_progress(progress):
    """``progress``, or :data:`SILENT` when None.

    Examples
    --------
    >>> as_progress(None) is SILENT
    True
    """
    return SILENT if progress is None else progress


def start_reporter(progress, bar, what):
    """``on_start(k, n, fun)`` for a likelihood search: the bar and a line.

    The callback of the optimisers' starts (the emulator's and module 2's):
    it advances ``bar`` by one start and writes the detail line ``{what}:
    start k of n, log-likelihood ...`` (``fun`` is the minimised
    ``-loglik``). A new search (``k == 1`` after others, as when the
    emulator's nugget is escalated) adds its starts to the bar's total.

    Examples
    --------
    >>> progress = Progress(0)
    >>> with progress.bar(2, "starts") as bar:
    ...     on_start = start_reporter(progress, bar, "emulator")
    ...     on_start(1, 2, -10.0)
    ...     on_start(2, 2, -12.0)
    >>> bar.n
    2
    """

    def on_start(k, n, fun):
        if k == 1 and bar.n:
            bar.total = bar.n + n
            bar.refresh()
        bar.update(1)
        progress.detail(f"{what}: start {k} of {n}, log-likelihood {-fun:.6g}")

    return on_start


def results_as_ready(tasks, n_jobs=None):
    """Run joblib tasks; yield their results in order, each once it is done.

    Lets the parent process update a bar while workers run: with
    ``return_as="generator"``, a result is available as soon as it and the
    tasks before it are finished. Backends that cannot return a generator
    (``"multiprocessing"``) run all tasks first. The results, and their
    order, are those of ``Parallel(n_jobs)(tasks)``.

    Parameters
    ----------
    tasks : iterable of joblib.delayed calls
    n_jobs : int, default=None
        As for :class:`joblib.Parallel` (joblib's context applies).

    Examples
    --------
    >>> from joblib import delayed
    >>> list(results_as_ready(delayed(pow)(2, k) for k in range(4)))
    [1, 2, 4, 8]
    """
    try:
        parallel = Parallel(n_jobs=n_jobs, return_as="generator")
    except ValueError:  # the backend cannot return a generator
        parallel = Parallel(n_jobs=n_jobs)
    yield from parallel(tasks)


def duration_text(seconds):
    """A time for people: ``"40 s"``, ``"12 min"``, ``"3.5 h"``.

    Examples
    --------
    >>> duration_text(40.2), duration_text(725.0), duration_text(12600.0)
    ('40 s', '12 min', '3.5 h')
    """
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
