"""The monitor: residuals, detection and decisions on a stream of samples, as events.

``bgfdi monitor model.yaml DATA`` (DATA a CSV file, or ``-`` for a CSV stream on standard input)
feeds the samples to a :class:`Stream` (``Monitor.stream``) block by block and prints one JSON object per line for
each event, in stream time:

- ``start``: the residuals, their thresholds, and the lag of the derivative estimate;
- ``detection``: the first excursion confirmed by the persistence rule (:mod:`fdi.detect`): its
  start t_D, its ``alarm`` and the coherence vector there;
- ``coherence``: every later change of the latched coherence vector (at the new residual's alarm);
- ``decision``: at the alarm + T_wt (once the N identification samples have arrived), and again T_wt
  after each later change of the coherence vector: candidate sets, the identified faults, the
  fault-mode estimate, and the prognosis (RUL and its band) of incipient faults;
- ``decision`` too where a decision's fit stops explaining the samples that follow (a lack of
  fit, :func:`fdi.pipeline.misfit_at`): every ``refresh`` seconds the samples since the last look
  are judged against the fit (:func:`fdi.pipeline.refuted`, each sample once), while it has no
  mode fault and no prognosis to refresh, has seen under six windows and explains its own; where
  they refute it, the samples so far are diagnosed again;
- ``prognosis``: every ``refresh`` seconds (an identification window by default) after a
  decision with a growing fault, its fit
  refreshed on the data so far (:func:`fdi.pipeline.refresh_prognosis`) and the RUL re-issued;
  and once more at the end of the stream where the last fit is a refresh period older than the
  last sample (a live stream that ended while the decision was being identified);
- ``summary``: at the end of the stream, the report ``bgfdi diagnose --json`` gives for the same
  samples (the same engine: the final decisions are recomputed on all the data, reusing every
  identification whose data window has not changed).

Each event carries ``t`` (the stream time it refers to) and ``known_at`` (the time of the last
sample received when it was emitted): the difference is the latency of the method, chiefly the
waiting time and the identification window, plus the lag.

Identification takes seconds, so a decision (and a prognosis refresh) runs in a worker
(:class:`Worker`: one process) while the samples keep being read, their residuals computed and
detection and coherence events emitted. At most one identification is in flight; decision times
that come due meanwhile are coalesced into the next one (a monitor in the field cannot queue
copies of its record without bound). Each is computed on the samples received when it came due,
as it was before the worker (the same decisions, the same seed), and emitted when it finishes,
with ``known_at`` the stream time then and ``identification_s`` the wall-clock seconds it took.
A recorded file is replayed with ``live=False``: the stream waits for each identification, as if
it took no stream time, and the events are the same on every run. ``close`` waits for the work
in flight before the summary.

Residuals are causal up to a lag: the Savitzky–Golay derivative at time t needs the samples up to
t + W/2 (W the derivative window), so a residual sample is final, and used for detection, half a
window after it was measured (0.125 s on the CyCab). A model file that gives no window leaves it
to the data (:mod:`fdi.scales`): the ``start`` event then comes with the first two samples. Each
residual sample is computed once, from the filter state the buffer carries (:mod:`fdi.carry`:
half a window of samples read on each side, none filtered twice), and equals the whole file's.
``feed(header, rows, rows=B)`` takes a parsed chunk as consecutive blocks of B rows: the events of
feeding them one by one, with the residuals and the persistence rule run once over the chunk while
nothing is detected (``bgfdi monitor`` on a recording: an hour at 100 Hz in 0.3 s of CPU).
"""
from __future__ import annotations

import math
import os
import signal
import time
import weakref
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from bondgraph.errors import ModelError
from bondgraph.timescales import model_time_scales

from . import scales
from .carry import Carried
from .data import DataError, Measurements, check_header, checked
from .detect import confirmed, evidence, evidence_samples, settling, span_start, stray_error, thresholds_for
from .options import Options
from .episodes import MAX_GROWTH
from .pipeline import refresh_prognosis, refuted, with_overrides, with_samples
from .residuals import never_finite_text
from .results import Diagnosis, plain

HISTORY_SAMPLES = 360_000   # samples kept before a detection when no history in seconds is given
NEVER_WINDOWS = 10          # derivative windows (and at least N samples) a residual may have none finite before
                            # a stream is refused

if TYPE_CHECKING:
    from .monitor import Monitor

Emit = Callable[[dict], None]

_installed: "Monitor | None" = None        # the worker process's monitor (installed once, at its start)


def _install(monitor: "Monitor") -> None:
    """The worker process's initializer: its own process group (so that the stream, on Ctrl-C or
    SIGTERM, ends it and the estimator pool it may open in one signal: no orphan), and the
    monitor (with ``fork``, the parent's derivation, inherited; else derived once)."""
    global _installed
    if hasattr(os, "setpgid"):
        os.setpgid(0, 0)
    signal.signal(signal.SIGINT, signal.SIG_IGN)      # the stream decides when its worker ends
    _installed = monitor


def _diagnose(monitor: "Monitor | None", meas: Measurements, options: Options, memo: dict) -> tuple:
    """A decision in the worker: the report, the diagnosis without its residuals (for refreshes),
    the memo entries it added (handed back: the next decision reuses them) and its seconds."""
    start = time.perf_counter()
    mine = dict(memo)
    d = (monitor or _installed).diagnose(meas, options, memo=mine)
    fresh = {k: v for k, v in mine.items() if k not in memo}
    return d.to_dict(), replace(d, t=None, residuals=None), fresh, time.perf_counter() - start


def _misfit(monitor: "Monitor | None", meas: Measurements, latest: Diagnosis, options: Options,
            since: float | None) -> tuple:
    """A lack-of-fit check in the worker (:func:`fdi.pipeline.refuted`): its answer and seconds (None,
    no check, where the samples are not ones a diagnosis reads: the decisions say why)."""
    start = time.perf_counter()
    try:
        answer = refuted(monitor or _installed, meas, latest, options, since)
    except (DataError, ModelError):
        answer = None
    return answer, time.perf_counter() - start


def _ordinal(k: int) -> str:
    """1st, 2nd, 3rd, 4th, 11th, 21st, 1501st."""
    return f"{k}{'th' if 10 <= k % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(k % 10, 'th')}"


def _refresh(monitor: "Monitor | None", meas: Measurements, latest: Diagnosis, options: Options,
             memo: dict) -> tuple:
    """A prognosis refresh in the worker: faults, prognosis, new memo entries, seconds."""
    start = time.perf_counter()
    mine = dict(memo)
    faults, prognosis = refresh_prognosis(monitor or _installed, meas, latest, options, mine)
    fresh = {k: v for k, v in mine.items() if k not in memo}
    return faults, prognosis, fresh, time.perf_counter() - start


class Worker:
    """Where a stream's identifications run, one at a time: ``"process"`` (one worker process; the
    reader keeps the interpreter to itself) or ``"thread"`` (shares the interpreter lock with the
    reader). ``submit`` hands over the job, ``result`` waits for it, ``stop`` ends the worker,
    killing its process group when ``now`` (Ctrl-C, SIGTERM, an error)."""

    def __init__(self, monitor: "Monitor", kind: str = "process") -> None:
        if kind not in ("process", "thread"):
            raise ValueError(f"worker: 'process' or 'thread', not {kind!r}")
        self.monitor, self.kind = monitor, kind
        self._pool: Executor | None = None

    def start(self) -> None:
        """Open the worker ahead of its first job (a process starts while the samples flow)."""
        if self._pool is None:
            if self.kind == "thread":
                self._pool = ThreadPoolExecutor(1, thread_name_prefix="bgfdi-identify")
            else:
                self._pool = ProcessPoolExecutor(1, initializer=_install, initargs=(self.monitor,))
                self._pool.submit(int)                  # the process starts now, not at the first job
            weakref.finalize(self, self._pool.shutdown, wait=False)    # a stream dropped unclosed

    def submit(self, fn: Callable[..., tuple], *args: Any) -> Future:
        self.start()
        assert self._pool is not None
        return self._pool.submit(fn, None if self.kind == "process" else self.monitor, *args)

    def stop(self, now: bool = False) -> None:
        """End the worker: after its job, or ``now``, killing its process group (the worker and
        any estimator pool it opened) so that no process outlives the stream."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if now and isinstance(pool, ProcessPoolExecutor):
            for p in list(getattr(pool, "_processes", {}).values()):
                try:
                    os.killpg(p.pid, signal.SIGKILL) if hasattr(os, "killpg") else p.kill()
                except (ProcessLookupError, PermissionError):     # not yet its own group: itself
                    p.kill()
        pool.shutdown(wait=not now or isinstance(pool, ProcessPoolExecutor), cancel_futures=now)


@dataclass
class Stream:
    """A stream's state: its samples, its final residuals, and where detection and decisions stand.
    ``feed`` takes blocks of rows; ``close`` ends the stream and returns the diagnosis of every
    sample received (the ``summary`` event)."""
    monitor: "Monitor"
    emit: Emit
    options: Options | None = None
    source: str = "<stream>"
    header: list[str] = field(default_factory=list)
    n: int = 0                          # samples in the buffer (received, less those forgotten)
    forgotten: int = 0                  # samples dropped from the buffer's start (history)
    finite_seen: "np.ndarray | None | bool" = None   # per residual, a finite final sample seen (False: all had)
    judged: int = 0                     # final samples with some residual finite (while one never was)
    done: int = 0                       # samples whose residuals are final
    residuals: np.ndarray | None = None   # the residuals the last feed made final (residuals x samples)
    history: float | None = None        # s of samples kept before a detection (bounded memory); None:
                                        # HISTORY_SAMPLES samples, whatever the rate
    t_detect: float | None = None
    lit: np.ndarray | None = None       # latched coherence
    recent: np.ndarray | None = None    # each residual's evidence over the last span (fdi.detect)
    recent_t: np.ndarray | None = None  # and its times
    pending: list[float] = field(default_factory=list)       # decision times not yet reached
    decided: int = 0                    # decisions emitted
    memo: dict = field(default_factory=dict)
    refresh: float | None = None        # s between prognosis refreshes; None: an identification window
    ts: float = math.nan                # the sampling period, from the first two samples
    latest: Diagnosis | None = None     # the last decision
    next_refresh: float = math.inf
    fitted_to: float = math.inf         # the time the latest prognosis is given at (its fit's last sample)
    live: bool = True                   # samples arrive in real time: read on while identifying
    worker: str = "process"             # where identifications run (Worker)
    due: int | None = None              # samples received when the next decision came due (coalesced)
    job: tuple[str, Future, int] | None = None     # the identification in flight: kind, future, samples
    carried: Carried | None = None      # the residual kernels on the stream's columns (fdi.carry)
    checked_to: float | None = None     # the last sample the latest decision's fit was judged to (None: not yet)
    settled: bool = False               # no later sample can refute the latest decision's fit (fdi.pipeline.refuted)
    closed: Callable[[], None] | None = None   # called after the summary (Monitor.stream: fdi.monitor.persist)

    def __post_init__(self) -> None:
        # the stream's detection reads every sample as recorded (its filters carry state block to block),
        # so its decisions do too: a glitch the diagnosis repaired was announced, then never decided
        self.options = replace(self.options or Options(), keep_spikes=True)
        self.options.check()
        self.monitor = with_overrides(with_samples(self.monitor.with_config(self.options.settings),
                                                   self.options.samples), self.options.thresholds)
        c = self.monitor
        self.model, self.config, self.compiled = c.model, c.config, c.residuals
        self.names = list(c.names)
        if (stray := stray_error(self.model, self.config.thresholds, self.names)) is not None:
            raise stray
        try:
            self.thresholds = thresholds_for(self.config.thresholds, self.names, self.options.thresholds)
        except ValueError as exc:           # the model's thresholds: one line naming the file and the key
            raise ModelError(str(exc), file=self.model.path, where="thresholds") from None
        self.wait = self.config.waiting_time if self.options.waiting_time is None else self.options.waiting_time
        self.samples = self.options.samples or self.config.samples
        self.window = None
        self.identifier = Worker(self.monitor, self.worker)
        if self.config.derivative_window is not None and self.wait is not None:
            self._start()               # else once two samples tell the sampling time (fdi.scales)

    def _start(self, ts: float | None = None) -> None:
        """The derivative window, its lag and the waiting time, and the ``start`` event. Times the
        model file leaves out come from the sampling time ``ts`` and the model (fdi.scales)."""
        if ts is not None:
            self.ts = ts
            self.monitor, sc = self.monitor.scaled(ts)
            self.identifier.monitor = self.monitor
            self.config = self.monitor.config
            self.wait = self.config.waiting_time if self.options.waiting_time is None else self.options.waiting_time
            self.samples = self.options.samples or max(self.config.samples, sc.min_samples())
        self.window = self.config.derivative_window
        self.lag = self.window / 2
        self.persistence, self.span = scales.detection_rule(self.window, self.wait, self.options.persistence,
                                                            self.config.persistence)
        self.settle = settling(self.options.settle, scales.settle(self.window, model_time_scales(self.model).eigenvalues))
        self.emit({"event": "start", "model": self.model.name, "residuals": self.names,
                   "thresholds": dict(zip(self.names, map(float, self.thresholds))), "lag_s": self.lag,
                   "waiting_time_s": self.wait})

    # ------------------------------------------------------------------ data in
    def feed(self, header: list[str], block: np.ndarray, rows: int | None = None) -> None:
        """A block of rows (columns of ``header``, one of them ``t``). With ``rows``, the block is
        taken as consecutive blocks of that many rows, fed one after another (``bgfdi monitor
        --block``): the same events, but while nothing is detected the residuals and the
        persistence rule run once over all of them (:meth:`_bulk`), so a reader that parsed
        thousands of rows at once hands them over in one call."""
        if not self.header:
            check_header(self.source, list(header))
            self.header = list(header)
            self.buffer = np.empty((1024, len(header)))
            self.ti = self.header.index("t")
        if block.size == 0:
            return
        if rows is None or block.shape[0] <= rows:
            self._one(block)
            return
        self.residuals = None
        pieces, a, bulk = [], 0, True
        while a < block.shape[0]:
            used = self._bulk(block[a:], rows) if bulk else 0
            if self.residuals is not None:
                pieces.append(self.residuals)
                self.residuals = None
            if used:
                a += used
                bulk = a >= block.shape[0]          # stopped short: an alarm in the next block, which goes alone
                continue
            bulk = self._bulk_ready() is None    # declined for a reason a block may end (the start): try on; else per block
            self._one(block[a:a + rows])
            a += rows
        if pieces:
            self.residuals = np.concatenate(pieces + ([] if self.residuals is None else [self.residuals]), axis=1)

    def _one(self, block: np.ndarray) -> None:
        """One block of rows: appended, the residuals that became final computed from the carried
        samples (:mod:`fdi.carry`), then detection, decisions, refreshes and forgetting."""
        self._append(block)
        if self.n < 3:
            return
        t = self.buffer[:self.n, self.ti]
        ts = float(t[1] - t[0])
        if self.window is None:
            self._start(ts)
        elif math.isnan(self.ts):           # a model file that gave every time: _start had no ts
            self.ts = ts
        margin = int(math.ceil(self.window / ts)) + 1
        final = self.n - int(math.ceil(self.lag / ts)) - 1          # residuals final up to here (exclusive)
        if final <= self.done or self.n <= 2 * margin:
            return
        a = max(0, self.done - self._carried().behind(ts))
        self.residuals = self._carried()(self.buffer[a:self.n], ts, self.done - a, final - a)
        self._watch(self.residuals, ts)
        start, self.done = self.done, final
        self._detect(t, start, final)
        self._decide()
        self._refresh()
        self._forget(ts, margin)

    def _watch(self, r: np.ndarray, ts: float) -> None:
        """A residual not finite on any of NEVER_WINDOWS derivative windows of final samples on which
        another is, nor on an identification window's N (a law that leaves its domain on these data),
        refuses the stream there, as a file is refused (:func:`fdi.pipeline.never_finite`), not at its
        end hours later (a start-up stretch outside a law's domain, finite later, is the file's to
        accept: N samples of it are not); only where the model has no modes (their switches leave
        samples out by design, which the file's check tells apart)."""
        if self.finite_seen is False or self.model.modes or not r.size:
            return
        f = np.isfinite(r)
        seen = f.any(axis=1) if self.finite_seen is None else self.finite_seen | f.any(axis=1)
        if seen.all():
            self.finite_seen = False            # every residual has a sample: nothing more to watch
            return
        self.finite_seen = seen
        self.judged += int(f.any(axis=0).sum())
        if self.judged >= max(NEVER_WINDOWS * max(1, int(round(self.window / ts))), self.samples):
            names = [res.name for res, ok in zip(self.compiled, seen) if not ok]
            raise DataError(f"{self.source}: {never_finite_text(self.model, self.compiled, names)}")

    def _carried(self) -> Carried:
        """The residual kernels on the stream's columns (made once, at the first block)."""
        if self.carried is None:
            self.carried = Carried(self.model, list(self.compiled), self.window, self.header, self.options.mode,
                                   self.source)
        return self.carried

    def _bulk_ready(self) -> bool | None:
        """Whether :meth:`_bulk` may take blocks at once: True; None before the stream has started
        (a block may start it); False once detected, with decisions pending or identifying, or on
        the whole-segment path."""
        if self.window is None or self.n < 3:
            return None
        return self.t_detect is None and not self.pending and self.job is None and self.due is None \
            and self.latest is None and self._carried().cropped

    def _bulk(self, block: np.ndarray, rows: int) -> int:
        """Blocks of ``rows`` rows of ``block`` taken at once while nothing is detected or due: the
        per-block bookkeeping (which samples each block makes final, when rows are forgotten) is
        replayed in integers, the residuals of all of them computed in one call, and the
        persistence rule run over them with the evidence carried before. The blocks before the
        one whose residuals confirm an alarm are committed; the rows consumed are returned, the
        rest go block by block (:meth:`_one`: the detection event with its ``known_at``). Rows
        that :meth:`_append` would refuse also go block by block (the error at its block), and so
        do models on the whole-segment path of :mod:`fdi.carry` (stored quantities, mode switches),
        whose residuals near a block's end depend on where the block ends."""
        if self._bulk_ready() is not True or not self._acceptable(block):
            return 0
        ti, m = self.ti, block.shape[0]
        ts = float(self.buffer[1, ti] - self.buffer[0, ti])
        margin = int(math.ceil(self.window / ts)) + 1
        lag = int(math.ceil(self.lag / ts)) + 1
        keep = max(self._kept(ts), 4 * margin)
        n, done, dropped = self.n, self.done, 0      # the buffer's rows, final residuals, rows forgotten
        plan = []                                    # per block: (end, final, buffer start), rows from the buffer's start now
        for a in range(0, m, rows):
            n += min(rows, m - a)
            final = n - lag
            if final <= done or n <= 2 * margin:
                plan.append((n + dropped, None, dropped))
                continue
            plan.append((n + dropped, final + dropped, dropped))
            done = final
            if n >= 2 * keep:
                drop = min(n - keep, done - 2 * margin)
                if drop > 0:
                    n, done, dropped = n - drop, done - drop, dropped + drop
        finals = [(j, f) for j, (_, f, _) in enumerate(plan) if f is not None]
        commit = len(plan)
        z = None
        if finals:
            base = max(0, self.done - self._carried().behind(ts))
            table = np.concatenate([self.buffer[base:self.n], block])
            hi = finals[-1][1]
            r = self._carried()(table, ts, self.done - base, hi - base)
            self._watch(r, ts)
            t_at = table[self.done - base:hi - base, ti]
            # the buffer's first time when each sample was checked (detection ignores the settling time)
            first = np.empty(hi - self.done)
            lo = self.done
            for j, f in finals:
                start = plan[j][2]
                first[lo - self.done:f - self.done] = self.buffer[start, ti] if start < self.n else table[start - base, ti]
                lo = f
            n_ev = evidence_samples(self.span, ts)
            z = evidence(r, self.thresholds, ts, t_at >= first + self.settle)
            if self.recent is None:
                self.recent, self.recent_t = np.zeros((z.shape[0], n_ev - 1)), np.full(n_ev - 1, -np.inf)
            fired = confirmed(z, n_ev, self.persistence, self.recent).any(axis=0)
            if fired.any():
                at = self.done + int(np.argmax(fired))
                commit = next(j for j, f in finals if f > at)
        used = min(m, commit * rows)
        done0 = self.done
        if self.n + used < 2 * keep:                   # nothing forgotten meanwhile: the rows in one copy
            self._append(block[:used], checked=True)
            self.done = max([self.done] + [f for j, f in finals if j < commit])
            used_rows = 0
        else:
            used_rows = used
        for a in range(0, used_rows, rows):            # the blocks before an alarm: rows kept, samples final, forgetting
            self._append(block[a:a + rows], checked=True)
            t = self.buffer[:self.n, ti]
            ts_now = float(t[1] - t[0])
            final = self.n - int(math.ceil(self.lag / ts_now)) - 1
            if final <= self.done or self.n <= 2 * margin:
                continue
            self.done = final
            self._forget(ts_now, margin)
        if z is not None:
            upto = next((f for j, f in reversed(finals) if j < commit), None)
            if upto is not None:
                k = upto - done0
                zs = np.concatenate([self.recent, z[:, :k]], axis=1)
                ts_all = np.concatenate([self.recent_t, t_at[:k]])
                self.recent, self.recent_t = zs[:, zs.shape[1] - (n_ev - 1):], ts_all[ts_all.size - (n_ev - 1):]
                self.residuals = r[:, :k]
        return used

    def _kept(self, ts: float) -> int:
        """Samples kept before a detection: ``history`` seconds of them, or HISTORY_SAMPLES (an
        hour at the CyCab's 100 Hz, 100 hours of a thermal system sampled each second, 36 s at
        10 kHz: one memory bound, 17 MB for 6 columns, where an hour in seconds held 1.7 GB at
        10 kHz)."""
        return HISTORY_SAMPLES if self.history is None else int(math.ceil(self.history / ts))

    def _forget(self, ts: float, margin: int) -> None:
        """Before a detection, rows older than the history (:meth:`_kept`) are dropped, so a stream
        watched for days holds at most that much (an hour of 8 columns at 100 Hz: 23 MB). The rows are
        shifted once as many have aged out as are kept (amortised: each row is copied once); the
        margin the next residual block needs stays. A stream no longer than ``history`` keeps
        every sample, and its summary is ``bgfdi diagnose`` on the whole file."""
        # a decision diagnoses the rows kept, and detection there waits the settling time from their
        # first one again: keep it and four windows beyond (--history 1 s against a mass-spring's 2.8 s
        # start-up settling: the fault never detected, the summary "nothing detected")
        keep = max(self._kept(ts), 4 * margin, int(math.ceil((self.settle + 4 * self.window) / ts)))
        if self.t_detect is not None or self.n < 2 * keep:
            return
        drop = min(self.n - keep, self.done - 2 * margin)
        if drop <= 0:
            return
        self.buffer[:self.n - drop] = self.buffer[drop:self.n].copy()
        self.n -= drop
        self.done -= drop
        self.forgotten += drop

    def _acceptable(self, block: np.ndarray) -> bool:
        """Whether :meth:`_append` takes every row of ``block`` (in blocks of any size): finite, and
        each time step the first one's within 1e-3 (the tolerance of the sample's own time, no
        looser than a block's)."""
        if self.n < 2 or not np.isfinite(block).all():
            return False
        ts = self.buffer[1, self.ti] - self.buffer[0, self.ti]
        t = np.concatenate([self.buffer[self.n - 1:self.n, self.ti], block[:, self.ti]])
        return bool(ts > 0 and np.all(np.abs(np.diff(t) - ts) <= 1e-3 * ts + 1e-9 * np.abs(t[1:])))

    def _append(self, block: np.ndarray, checked: bool = False) -> None:
        """Rows into the buffer (grown by doubling), each block checked as read_csv checks a file:
        finite values, time increasing with the first step, uniform within 1e-3 of it (unless
        ``checked``: :meth:`_acceptable` said so)."""
        if not checked:
            bad = np.flatnonzero(~np.isfinite(block).all(axis=1))
            if bad.size:
                k = self.forgotten + self.n + int(bad[0]) + 1      # from 1, the rows forgotten counted
                raise DataError(f"{self.source}: a row with NaN, infinite or missing values at sample {k} (its "
                                f"{_ordinal(k)} data row, blank lines not counted); remove or fill it")
        while self.n + block.shape[0] > self.buffer.shape[0]:
            self.buffer = np.concatenate([self.buffer, np.empty_like(self.buffer)])
        self.buffer[self.n:self.n + block.shape[0]] = block
        self.n += block.shape[0]
        if checked:
            return
        t = self.buffer[max(0, self.n - block.shape[0] - 1):self.n, self.ti]
        if self.n >= 2:
            ts = self.buffer[1, self.ti] - self.buffer[0, self.ti]
            dt = np.diff(t)
            if ts <= 0 or np.any(np.abs(dt - ts) > 1e-3 * ts + 1e-9 * abs(t[-1])):
                k = int(np.argmax(np.abs(dt - ts) > 1e-3 * ts)) if dt.size else 0
                raise DataError(f"{self.source}: time must increase by a constant step ({ts:g} s at first); "
                                f"step {dt[k] if dt.size else ts:g} s at t = {t[min(k + 1, t.size - 1)]:g} s")

    def measurements(self) -> Measurements:
        """Every sample received, checked as a file is."""
        return checked(self.source, self.header, self.buffer[:self.n])

    # ------------------------------------------------------------------ detection
    def _detect(self, t: np.ndarray, start: int, stop: int) -> None:
        """The block's final residuals through the persistence rule (:mod:`fdi.detect`), with the
        evidence of the last span carried from the blocks before: the same alarms as on the
        whole file."""
        ts = float(t[1] - t[0])
        n = evidence_samples(self.span, ts)
        z = evidence(self.residuals, self.thresholds, ts, t[start:stop] >= t[0] + self.settle)
        if self.recent is None:
            self.recent, self.recent_t = np.zeros((z.shape[0], n - 1)), np.full(n - 1, -np.inf)
        head, head_t = self.recent, self.recent_t
        fired = confirmed(z, n, self.persistence, head)
        zs, ts_all = np.concatenate([head, z], axis=1), np.concatenate([head_t, t[start:stop]])
        self.recent, self.recent_t = zs[:, zs.shape[1] - (n - 1):], ts_all[ts_all.size - (n - 1):]
        known_at = float(t[self.n - 1])
        for k in np.flatnonzero(fired.any(axis=0)):
            now = fired[:, k] & (self.lit is None or ~self.lit)
            if not now.any():
                continue
            alarm = float(t[start + k])
            at = head.shape[1] + k                          # the alarm's column in zs (head, then this block)
            began = min(float(ts_all[span_start(zs[i], at, n)]) for i in np.flatnonzero(now))
            if self.lit is None:
                self.lit = now.copy()
                self.t_detect = began
                self.emit({"event": "detection", "t": self.t_detect, "alarm": alarm,
                           "coherence": self.lit.astype(int).tolist(), "known_at": known_at})
                if self.live:
                    self.identifier.start()     # the worker starts while the waiting time passes
                self.pending.append(alarm + self.wait)
                continue
            self.lit |= now
            self.emit({"event": "coherence", "t": alarm, "began": began,
                       "coherence": self.lit.astype(int).tolist(), "known_at": known_at})
            if self.decided or not self.pending or alarm > self.pending[0]:    # else the first decision's
                self.pending.append(alarm + self.wait)

    # ------------------------------------------------------------------ decisions
    def _decide(self) -> None:
        """Once a decision time has passed and the data it needs (N samples from t_D, the filter's
        margin) have arrived, the diagnosis of the samples so far is handed to the worker (or, with
        one in flight, kept for when it ends: later decision times coalesce into one)."""
        self._collect()
        if not self.pending or self.t_detect is None:
            return
        t = self.buffer[:self.n, self.ti]
        t_now, margin = float(t[self.done - 1]), self.window + 2 * (t[1] - t[0])
        t_last = float(t[-1])
        ready = self.t_detect + self.samples * (t[1] - t[0]) + margin     # the first window and its margin
        due = [d for d in self.pending if d <= t_now and d + margin <= t_last]
        if not due or t_last < ready:
            return
        self.pending = [d for d in self.pending if d not in due]
        self.due = self.n
        self._submit()

    def _submit(self) -> None:
        """The due decision to the worker, when none is in flight: the samples received when it
        came due (after a detection no sample is dropped: the first ``due`` rows are final)."""
        if self.job is not None or self.due is None:
            return
        n, self.due = self.due, None
        meas = checked(self.source, self.header, self.buffer[:n])
        self.job = ("decision", self.identifier.submit(_diagnose, meas, self.options, self.memo), n)
        if not self.live:
            self._collect(wait=True)

    def _collect(self, wait: bool = False) -> None:
        """The identification in flight, if it has ended (or ``wait`` for it): its events, stamped
        with the stream time now; then the next due decision goes to the worker."""
        while self.job is not None and (wait or self.job[1].done()):
            kind, future, n = self.job
            result = future.result()
            self.job = None
            known_at = float(self.buffer[self.n - 1, self.ti])
            if kind == "decision":
                report, self.latest, fresh, seconds = result
                self.fitted_to = min((g.at for g in self.latest.prognosis), default=math.inf)
                self.memo.update(fresh)
                self._report_decisions(report, known_at, seconds)
                self.next_refresh = known_at + self._refresh_period()
                self.checked_to, self.settled = None, False
            elif kind == "misfit":
                refuted_now, _ = result
                self.settled = refuted_now is None
                self.checked_to = float(self.buffer[n - 1, self.ti])
                if refuted_now:                 # decided again on the samples so far (fdi.pipeline.later_decisions)
                    self.due = self.n
            else:
                faults, prognosis, fresh, seconds = result
                self.fitted_to = min((g.at for g in prognosis), default=math.inf)
                self.memo.update(fresh)
                self.emit({"event": "prognosis", "t": float(self.buffer[n - 1, self.ti]),
                           "faults": [f for f in faults if f["type"] == "incipient"],
                           "prognosis": plain([p.to_dict() for p in prognosis]), "known_at": known_at,
                           "identification_s": seconds})
            self._submit()

    def _refresh_period(self) -> float:
        """Seconds of data between prognosis refreshes: ``refresh``, or one identification window,
        N ts: a refit sees a window more each time (the CyCab's 10 s, the tutorial's RC filter 5 s;
        a thermal system's 1 000 samples of a second, 17 minutes: the former 5 s of data was a refit
        every 5 samples there, each taking seconds, and one every 2.5 windows of the CyCab)."""
        if self.refresh is not None:
            return self.refresh
        return self.samples * self.ts

    def _refutable(self) -> bool:
        """Whether the latest decision's fit is one a lack of fit decides again
        (:func:`fdi.pipeline.misfit_at`): component faults without a prognosis, fitted on fewer than
        the longest window a decision fits, explaining their own window."""
        d = self.latest
        if d is None or not d.faults or d.prognosis or any(f.type == "mode" for f in d.faults) or d.window is None \
                or self.settled:
            return False
        return d.window[1] - d.window[0] < MAX_GROWTH * self.samples * self.ts

    def _refresh(self) -> None:
        """Every refresh period (:meth:`_refresh_period`) after a decision with a growing fault, its
        fit refreshed on the data so far and the prognosis re-issued (a ``prognosis`` event), in
        the worker too; after one whose fit a lack of fit would refute (:meth:`_refutable`), the
        samples since the last look judged against the fit (:func:`fdi.pipeline.refuted`; each
        sample once, with the filters' and the detector's span of margin), and where they refute
        it a decision on the samples so far, whose new decisions are emitted (a step that keeps
        growing is decided again as it grows, not at the end of the stream)."""
        self._collect()
        if self.latest is None or self.pending or self.job is not None or self.due is not None:
            return
        refutable = self._refutable()
        if not self.latest.prognosis and not refutable:
            return
        t_last = float(self.buffer[self.n - 1, self.ti])
        if t_last < self.next_refresh:
            return
        self.next_refresh = t_last + self._refresh_period()
        if refutable:
            t = self.buffer[:self.n, self.ti]
            since = self.checked_to
            first = (self.latest.window[1] - self.samples * self.ts if since is None else since - self.span) \
                - 2 * self.window - 2 * self.ts
            a = max(0, int(np.searchsorted(t, first)))
            job = self.identifier.submit(_misfit, checked(self.source, self.header, self.buffer[a:self.n]),
                                         self.latest, self.options, since)
            self.job = ("misfit", job, self.n)
            if not self.live:
                self._collect(wait=True)
            return
        job = self.identifier.submit(_refresh, self.measurements(), self.latest, self.options, self.memo)
        self.job = ("prognosis", job, self.n)
        if not self.live:
            self._collect(wait=True)

    def _report_decisions(self, report: dict, known_at: float, seconds: float | None = None) -> None:
        """The decisions of ``report`` not yet emitted, in order; those of an identification carry
        ``identification_s``, its wall-clock seconds (the summary's are the summary's)."""
        decisions = []
        if report["detection"] is not None:
            first = {"t": report["detection"]["decision_time"], "coherence": report["detection"]["final_coherence"],
                     "candidates": report["candidates"], "faults": report["diagnosis"]["faults"]
                     if not report["episodes"] else report["episodes"][0]["previous"]}
            decisions.append(first)
        for e in report["episodes"] or []:
            decisions.append({"t": e["decision_time"], "coherence": e["coherence"], "candidates": e["candidates"],
                              "faults": e["faults"]})
        for d in decisions[self.decided:]:
            event = {"event": "decision", **d, "known_at": known_at}
            if d is decisions[-1]:
                event["faults"] = report["diagnosis"]["faults"]
                event["criterion_without"] = report["diagnosis"].get("criterion_without")
                event["mode"] = report["mode"]
                event["prognosis"] = report["prognosis"]
                event["note"] = report.get("note")
            elif d["faults"] is None:
                event.pop("faults")
            if seconds is not None:
                event["identification_s"] = seconds
            self.emit(event)
        self.decided = max(self.decided, len(decisions))

    def close(self) -> Diagnosis:
        """The end of the stream: the identifications in flight or due waited for (their events
        first), then the summary, the diagnosis of every sample received."""
        if self.n < 2:
            self.stop(now=True)
            raise DataError(f"{self.source}: the stream ended before two samples arrived")
        try:
            self._collect(wait=True)
            if self.n and float(self.buffer[self.n - 1, self.ti]) - self.fitted_to >= self._refresh_period():
                # a growing fault's fit a refresh period older than the last sample (a live stream read
                # faster than the decision's identification, a piped file: no refresh ran): one more
                self.next_refresh = -math.inf
                live, self.live = self.live, False
                try:
                    self._refresh()
                finally:
                    self.live = live
        finally:
            self.stop(now=self.job is not None)
        meas = self.measurements()
        if self.window is None:             # a stream of two samples: the start event still comes first
            self._start(meas.ts)
        d = self.monitor.diagnose(meas, self.options, memo=self.memo)
        out = d.to_dict()
        self._report_decisions(out, float(meas.t[-1]))
        self.emit({"event": "summary", **out})
        if self.closed is not None:
            self.closed()          # Monitor.stream's: what the stream derived kept for the next process
        return d

    def stop(self, now: bool = False) -> None:
        """End the worker: after its work, or ``now`` (Ctrl-C, SIGTERM, an error: its processes
        killed, nothing left running)."""
        self.job = None if now else self.job
        self.identifier.stop(now)
