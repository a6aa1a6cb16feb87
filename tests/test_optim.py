"""Engine operators against their equations (Yu & Wang 2014, eqs. 20-28) and engine behaviour."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import optim
from fdi import encoding
from fdi.app import synthetic
from fdi.encoding import FaultSpace
from optim import ENGINES, ahde_paper, bde, core, ga, shade
from optim.ahde import AHDE, AHDEOptions, Branch


def rng(seed=0):
    return np.random.default_rng(seed)


def test_de_best_1_mutation_eq20():
    x = np.array([[0.0], [1.0], [3.0], [7.0], [15.0]])
    f = np.full(5, 0.5)
    for seed in range(20):
        v = ahde_paper.real_mutation(rng(seed), x, best=2, f=f)
        for i in range(5):
            others = [x[j, 0] for j in range(5) if j != i]
            diffs = {round(3.0 + 0.5 * (a - b), 12) for a in others for b in others if a != b}
            assert round(v[i, 0], 12) in diffs


def test_binomial_crossover_eq21():
    target, mutant = np.zeros((50, 6)), np.ones((50, 6))
    none = core.binomial_crossover(rng(), target, mutant, 0.0)
    assert np.all(none.sum(axis=1) == 1)                       # only j_rand comes from the mutant
    assert np.all(core.binomial_crossover(rng(), target, mutant, 1.0) == 1)
    half = core.binomial_crossover(rng(), np.zeros((4000, 6)), np.ones((4000, 6)), 0.5)
    assert 0.5 < half.mean() < 0.65                            # CR plus the forced index


def test_greedy_selection_eq22_is_strict():
    assert core.select(np.array([1.0, 2.0, 3.0]), np.array([0.5, 2.0, 4.0])).tolist() == [True, False, False]


def test_binary_mutation_eq23_can_only_set_bits_and_freezes():
    bits = rng().random((30, 8)) < 0.5
    best = 3
    v = ahde_paper.binary_mutation(rng(1), bits, best)
    assert np.all(v | bits[best] == v)                        # X_best OR (...) keeps every bit of X_best
    same = np.tile(bits[best], (30, 1))                        # a population that agrees: every XOR is 0
    assert np.array_equal(ahde_paper.binary_mutation(rng(2), same, best), same)


def test_adaptive_law_at_im_0_and_1():
    cr_r, cr_b, f_r = ahde_paper.adaptive_rates(rng(), 0.0, 1000)
    assert np.all(cr_r == 0) and np.all(cr_b == 0) and np.all(f_r == 0)   # sin(0) = 0: finest search
    cr_r, cr_b, f_r = ahde_paper.adaptive_rates(rng(), 1.0, 20000)
    assert cr_r.max() <= 1 and cr_r.max() > 0.99 and cr_b.max() > 0.99
    assert f_r.max() <= 2 and f_r.max() > 1.98 and abs(f_r.mean() - 1.0) < 0.02
    half = ahde_paper.adaptive_rates(rng(), 0.5, 20000)[2]
    assert half.max() <= 2 * np.sin(np.pi / 4) + 1e-12


def test_improvement_measure_eq28():
    assert ahde_paper.improvement_measure(10.0, 10.0) == pytest.approx(1.0)
    assert ahde_paper.improvement_measure(10.0, 2.5) == pytest.approx(0.25)   # F(G-1)/F(G) = c(G)/c(G-1)


def test_midpoint_bound_repair():
    b = np.array([[0.0, 1.0]])
    out = core.repair_midpoint(np.array([[-3.0], [5.0], [0.3]]), np.array([[0.4], [0.8], [0.9]]), b)
    assert out[:, 0].tolist() == pytest.approx([0.2, 0.9, 0.3])


def test_distinct_partners_never_self():
    idx = core.distinct_indices(rng(), 6, 3)
    for i, row in enumerate(idx):
        assert i not in row and len(set(row)) == 3


@pytest.mark.parametrize("code, kind", [
    ((1, 0, 0), 0), ((0, 1, 0), 1), ((0, 0, 1), 2), ((0, 0, 0), 0), ((1, 1, 0), 0), ((1, 0, 1), 0),
    ((0, 1, 1), 1), ((1, 1, 1), 0)])
def test_zeta_repair(code, kind):
    assert encoding.repair_zeta(np.array([code], dtype=bool))[0] == kind


def test_keys_to_bits_one_hot_groups_are_always_valid():
    keys = rng().random((100, 10))
    bits = shade.keys_to_bits(keys, [(0, 1, 2), (5, 6, 7)])
    assert np.all(bits[:, :3].sum(axis=1) == 1) and np.all(bits[:, 5:8].sum(axis=1) == 1)
    assert np.array_equal(bits[:, 3], keys[:, 3] > 0.5)


def test_encode_decode_roundtrip():
    spaces = [FaultSpace.make("R4", np.inf, (1e6, 1e9)), FaultSpace.make("beta", 1.0, (0.05, 1.5))]
    truth = [{"type": "abrupt", "value": 2.5221e7}, {"type": "incipient", "model": 2, "b": [-0.03]}]
    real, bits = encoding.encode(spaces, truth)
    assert real.shape == (18,) and bits.shape == (10,)
    got = encoding.describe(spaces, real, bits)
    assert got[0]["type"] == "abrupt" and got[0]["value"] == pytest.approx(2.5221e7)
    assert got[1] == {"name": "beta", "type": "incipient", "model": 2, "eta": [0, 1], "b": [pytest.approx(-0.03)]}
    assert encoding.structure(spaces, bits) == (("abrupt", None), ("incipient", 2))


def test_ga_decoding_has_32_levels():
    genes = np.zeros((2, 5), dtype=bool)
    genes[1] = True
    assert ga.decode(genes, np.array([[0.0, 31.0]]), 5)[:, 0].tolist() == [0.0, 31.0]


def test_lehmer_mean():
    assert shade.lehmer(np.array([0.5, 1.0]), np.array([0.5, 0.5])) == pytest.approx(1.25 / 1.5)


def _sphere(real, bits):
    return ((real - 0.3) ** 2).sum(axis=1) + (bits != np.array([1, 0, 1])).sum(axis=1)


SPHERE = optim.pose(_sphere, bounds=[[-1, 1]] * 3, n_bits=3)


@pytest.mark.parametrize("name", sorted(ENGINES))
def test_every_engine_solves_a_mixed_sphere(name):
    r = optim.minimize(SPHERE, engine=name, pop=40, generations=80, seed=3)
    assert r.bits.tolist() == [True, False, True]
    assert r.cost < 1e-2
    assert len(r.history) >= 2
    if name == "AHDE":      # stops when its finalists have converged, never past the budget
        assert r.evaluations <= 40 * 81
    else:                   # the others spend it (GA re-uses its elite: pop - 1 per generation)
        assert r.evaluations >= 0.97 * 40 * 81
    assert r.history[-1] <= r.history[0]


@pytest.mark.parametrize("name", ["AHDE", "AHDE-paper", "SHADE"])
def test_seeded_runs_are_reproducible(name):
    a = optim.minimize(SPHERE, engine=name, pop=20, generations=20, seed=11)
    b = optim.minimize(SPHERE, engine=name, options=ENGINES[name].options(pop=20, generations=20, seed=11))
    assert a.cost == b.cost and np.array_equal(a.real, b.real)


def test_bde_finds_a_mode_vector():
    want = np.array([True, False])
    r = bde.minimize(lambda real, bits: (bits != want).sum(axis=1).astype(float), 2, pop=10, generations=20, seed=0)
    assert r.bits.tolist() == [True, False] and r.cost == 0


def test_stop_on_target_and_stagnation():
    r = optim.minimize(SPHERE, engine="AHDE-paper", pop=30, generations=500, seed=0, target=1e-3)
    assert r.stop == "target" and r.generations < 500
    flat = optim.minimize(optim.pose(lambda real, bits: np.ones(real.shape[0]), bounds=[[0, 1]]), engine="AHDE-paper",
                          pop=10, generations=100, stagnation=5, seed=0)
    assert flat.stop == "stagnation" and flat.generations == 5


def test_default_engine_identifies_fault_types_on_the_synthetic_problem():
    p = synthetic.problem("abrupt+intermittent", 0)
    r = optim.minimize(optim.pose(p.cost, bounds=p.bounds(), n_bits=p.n_bits, onehot=p.onehot, structure=p.structure))
    assert synthetic.recovered(p.spaces, p.truth, r.real, r.bits, p.t, p.t0)
    assert r.extra["margin"] > 1.0
    assert r.evaluations <= 150 * 301


def test_racing_on_a_coarse_objective_reports_the_fine_one():
    # the coarse objective ranks like the fine one but is offset by 100 (and counts its calls): the
    # engine must race on it and report the cost, history end and point of the fine objective
    calls = {"coarse": 0, "fine": 0}

    def fine(real, bits):
        calls["fine"] += real.shape[0]
        return _sphere(real, bits)

    def coarse(real, bits):
        calls["coarse"] += real.shape[0]
        return _sphere(real, bits) + 100.0

    r = optim.minimize(optim.pose(fine, bounds=[[-1, 1]] * 3, n_bits=3, coarse=coarse), pop=40, generations=80, seed=3)
    assert r.bits.tolist() == [True, False, True]
    assert r.cost == pytest.approx(float(_sphere(r.real[None, :], r.bits[None, :])[0])) and r.cost < 1e-2
    assert r.history[-1] == r.cost
    assert calls["coarse"] > 0 and calls["fine"] > 0 and r.evaluations == calls["coarse"] + calls["fine"]


def _branch(key, bits, free, x, f):
    n = len(f)
    return Branch(key, np.asarray(bits, dtype=bool), np.asarray(free), np.asarray(x, dtype=float),
                  np.asarray(f, dtype=float), np.ones(n), np.ones(n))


def test_each_family_keeps_its_best_structure_through_the_first_rungs():
    e = AHDE(optim.pose(_sphere, bounds=[[-1, 1]] * 3, n_bits=3, family=lambda b: int(b[0])), AHDEOptions())
    pool = [_branch("a", [0, 0, 0], [0], [[0, 0, 0]], [1.0]), _branch("b", [0, 1, 0], [0], [[0, 0, 0]], [1.1]),
            _branch("c", [1, 0, 0], [1], [[0, 0, 0]], [1.3]), _branch("d", [1, 1, 0], [1], [[0, 0, 0]], [1.4]),
            _branch("far", [0, 0, 1], [0], [[0, 0, 0]], [9.0])]
    kept = e.champions(pool, pool[:2])
    assert [b.key for b in kept] == ["c"]                  # family 1's best, within the spare of the leader (50 %)
    assert e.champions(pool, pool[:3]) == []                # a family already represented
    e.family = lambda b: (int(b[0]), int(b[2]))
    assert [b.key for b in e.champions(pool, pool[:2])] == ["c"]   # 'far' costs 9x the leader: not kept


def test_a_structure_left_behind_comes_back_with_the_winners_reals():
    # structure A (bit 0) and B (bit 1) share real 1: A's optimum is x1 = 0.7 at cost 1, B's the same x1 at
    # cost 0.1. B left the race with x1 = -0.5 (cost 5); the winner A has found x1 = 0.7: B must come back
    # as a finalist at cost 0.1, from a point with A's x1 and its own x2
    def cost(real, bits):
        b = np.asarray(bits, dtype=bool)
        a_cost = 1.0 + (real[:, 1] - 0.7) ** 2
        b_cost = 0.1 + (real[:, 1] - 0.7) ** 2 + (real[:, 2] - 0.2) ** 2
        return np.where(b[:, 1], b_cost, a_cost)

    e = AHDE(optim.pose(cost, bounds=[[-1, 1]] * 3, n_bits=2, onehot=[(0, 1)],
                        free=lambda b: np.array([False, True, bool(b[1])])), AHDEOptions())
    e.counter.objective = e.objective
    win = _branch(("A",), [1, 0], [1], [[0, 0.7, 0], [0, 0.6, 0]], [1.0, 1.01])
    left = _branch(("B",), [0, 1], [1, 2], [[0, -0.5, 0.2]], [5.0])
    e.describe = lambda b: ("A",) if b[0] else ("B",)
    e.branches = {win.key: win, left.key: left}
    finalists = [win]
    back = e.revive(finalists)
    assert back is left and finalists == [win, left]
    assert back.best == pytest.approx(0.1)
    assert back.x[int(np.argmin(back.f)), 1:].tolist() == pytest.approx([0.7, 0.2])
    assert e.revive([win, left]) is None                 # B now leads and A's point with B's x1 is worse


def test_eq18_is_searched_through_its_growth_rate():
    from scipy.integrate import solve_ivp
    space = FaultSpace.make("beta", 1.0, (0.05, 1.5))
    truth = {"type": "incipient", "model": 3, "b": [-3.0, -1.002]}
    real, bits = encoding.encode([space], [truth])
    r1 = (-3.0 + np.sqrt(13.0)) / 2                      # the growing root of s^2 - b3 s - 1
    assert real[4] == pytest.approx(np.log10(r1))
    assert encoding.describe([space], real, bits)[0]["b"] == [pytest.approx(-3.0), pytest.approx(-1.002)]
    # the decoded profile solves d2P/dt2 = b3 dP/dt + P + b4 from P = 1, dP/dt = 0
    t = np.linspace(0.0, 12.0, 121)
    (p,) = encoding.profiles([space], encoding.decode([space], real[None, :], bits[None, :]), t, 0.0)
    ode = solve_ivp(lambda _, y: [y[1], -3.0 * y[1] + y[0] - 1.002], (0, 12), [1.0, 0.0], t_eval=t, rtol=1e-10,
                    atol=1e-12)
    assert np.allclose(p[0], ode.y[0], atol=1e-8)
    # the bounds reach drifts far slower than b3 = -3 allowed (r1 >= 0.30/s): time constants up to 100 s
    lo, hi = encoding.bounds([space])[4]
    assert 10 ** lo == pytest.approx(0.01) and 10 ** hi == pytest.approx(10.0)
    slow = real.copy()
    slow[4] = lo
    assert encoding.describe([space], slow, bits)[0]["b"][0] < -3.7


# ---------------------------------------------------------------- the front door (issue 21)

@pytest.mark.parametrize("name", sorted(ENGINES))
def test_an_unknown_option_is_refused_naming_it_and_the_valid_ones(name):
    with pytest.raises(TypeError) as e:
        optim.minimize(SPHERE, engine=name, patiense=5)
    msg = str(e.value)
    assert "\n" not in msg and "'patiense'" in msg and name in msg and "pop, generations, seed" in msg


def test_a_misspelt_option_names_the_one_meant():
    with pytest.raises(TypeError, match=r"unknown option 'patiense' \(did you mean 'patience'\?\)"):
        optim.minimize(SPHERE, engine="AHDE", patiense=5)
    with pytest.raises(TypeError, match="'pc'"):                 # a GA's option is not the AHDE's
        optim.minimize(SPHERE, engine="AHDE", pc=0.5)
    with pytest.raises(ValueError, match="unknown engine 'ADHE'.*AHDE"):
        optim.minimize(SPHERE, engine="ADHE")
    with pytest.raises(TypeError, match="options must be AHDEOptions, not GAOptions"):
        optim.minimize(SPHERE, engine="AHDE", options=optim.GAOptions())
    with pytest.raises(ValueError, match=r"AHDEOptions\.pop must be a whole number >= 1, not 0"):
        optim.minimize(SPHERE, pop=0)
    with pytest.raises(ValueError, match=r"AHDEOptions\.eta must be a whole number >= 2"):
        optim.AHDEOptions(eta=1)


def test_options_are_frozen_and_overrides_replace_single_fields():
    o = optim.AHDEOptions(patience=7)
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.patience = 8
    assert core.configure("AHDE", optim.AHDEOptions, o, {"seed": 4}) == dataclasses.replace(o, seed=4)


def test_option_defaults_are_the_papers():
    # Yu & Wang 2014, Sec. IV-B: "Population size = 100, Maximum iterations = 150" for the diagnosis' AHDE;
    # Sec. IV-D (Table VI): population 150, 300 iterations, pc = 0.55, pm = 0.08 for every method, and the GA's
    # chromosomes "consisting of 5 bits each"
    a = optim.AHDEOptions()
    assert (a.pop, a.generations) == (100, 150)
    for cls in (optim.PaperOptions, optim.JointOptions, optim.GAOptions, optim.AGAOptions, optim.SHADEOptions,
                optim.ScipyDEOptions):
        assert (cls().pop, cls().generations) == (150, 300)
    g = optim.GAOptions()
    assert (g.pc, g.pm, g.bits_per_real) == (0.55, 0.08, 5)
    assert (optim.AGAOptions().pc, optim.AGAOptions().pm) == (0.55, 0.08)
    assert optim.PaperOptions().bit_flip == 0.0                # eq. (23) alone: the paper has no bit flip
    s = optim.SHADEOptions()                                    # Tanabe & Fukunaga 2014, L-SHADE's constants
    assert (s.memory, s.p_best, s.archive_rate, s.pop_min) == (6, 0.11, 2.6, 4)


class TwoStructures:
    """A problem on the protocol with a designed optimum: one fault of two types (one-hot bits 0, 1);
    type A reads real 0 and costs 1 + (x0 - 0.25)^2 at best 1; type B reads real 1 and costs
    (x1 + 0.6)^2 + |x1 + 0.6|, 0 at x1 = -0.6. Bit 2 is loose and costs 0.5 when set."""
    n_bits = 3
    onehot = [(0, 1)]

    def __call__(self, real, bits):
        a = 1.0 + (real[:, 0] - 0.25) ** 2
        d = real[:, 1] + 0.6
        return np.where(bits[:, 1], d ** 2 + np.abs(d), a) + 0.5 * bits[:, 2]

    def bounds(self):
        return np.array([[-1.0, 1.0], [-1.0, 1.0]])

    def structure(self, bits):
        return ("B" if bits[1] else "A", bool(bits[2]))

    def free(self, bits):
        return np.array([not bits[1], bool(bits[1])])


def test_minimize_reads_the_hooks_of_a_problem_and_finds_its_designed_optimum():
    p = optim.pose(TwoStructures())
    assert p.n_bits == 3 and p.onehot == ((0, 1),) and p.structure(np.array([0, 1, 1], bool)) == ("B", True)
    assert p.family is None and p.coarse is None and p.init == ()
    r = optim.minimize(TwoStructures(), seed=2)
    assert r.bits.tolist() == [False, True, False]
    assert r.real[1] == pytest.approx(-0.6, abs=1e-4) and r.cost < 1e-4
    assert r.extra["structures"][0] == (("B", False), r.cost)
    assert r.extra["raced"] == 4                               # 2 types x the loose bit: every structure raced
    for name in ("AHDE-joint", "SHADE"):                       # the engines that read the one-hot groups
        assert optim.minimize(TwoStructures(), engine=name, pop=30, generations=60, seed=2).bits.tolist() == \
            [False, True, False]


def test_pose_refuses_a_hook_it_does_not_know_and_inconsistent_bits():
    with pytest.raises(TypeError, match="unknown hook 'onehots' \\(did you mean 'onehot'\\?\\)"):
        optim.pose(TwoStructures(), onehots=[(0, 1)])
    with pytest.raises(ValueError, match="onehot names bit 3, outside the problem's n_bits = 3"):
        optim.pose(TwoStructures(), onehot=[(2, 3)])
    with pytest.raises(ValueError, match="init: a starting point has 2 reals and 2 bits"):
        optim.pose(TwoStructures(), init=[(np.zeros(2), np.zeros(2, bool))])
    with pytest.raises(TypeError, match="no bounds"):
        optim.pose(lambda real, bits: real[:, 0])


def test_a_run_without_its_check_resumed_finds_the_second_order_drift():
    """Designed truth: an intermittent fault (0.7, period 4.2 s) with an eq. (19) drift. The race
    ends with eq. (18), a smooth fit of another model; the final check, continued from the first
    pass's state (``extra["snapshot"]``, ``resume``), starts the eq. (19) family from the winner's
    profile re-expressed in eq. (19) (the ``translate`` hook) and recovers the truth."""
    p = synthetic.problem("intermittent+incipient19", 0)
    settings = dict(pop=150, generations=300)
    first = optim.minimize(p, engine="AHDE", seed=0, recheck=False, **settings)
    snapshot = first.extra["snapshot"]
    assert not synthetic.recovered(p.spaces, p.truth, p.finish(first.real, first.bits), first.bits, p.t, p.t0)
    done = optim.minimize(p, engine="AHDE", seed=0, resume=snapshot, **settings)
    assert done.evaluations > snapshot.evaluations                  # it continued, counting what was spent
    assert done.cost < first.cost
    assert synthetic.recovered(p.spaces, p.truth, p.finish(done.real, done.bits), done.bits, p.t, p.t0)
    # (without the translation the eq. (19) family started at its rim and was dropped on the way down
    # while eq. (19)'s b5 was searched in [-5, 5]; searched in [-20, 20] the untranslated family comes
    # back on this seed too, so that contrast is no longer a test)


def test_a_paused_race_resumed_ends_as_the_run_never_paused():
    """Designed truth: pausing is bookkeeping. A run paused after its first rung (``pause``) and
    continued from its snapshot ends with the point, cost, history and count of the run never
    paused, with or without its final check; the paused result is the race's leader costed on the
    fine objective (the race runs on the coarse one, offset by 100), one evaluation more."""
    p = synthetic.problem("abrupt+intermittent", 0)

    def coarse(real, bits):
        return p.cost(real, bits) + 100.0

    posed = optim.pose(p.cost, bounds=p.bounds(), n_bits=p.n_bits, onehot=p.onehot, structure=p.structure,
                       coarse=coarse)
    for recheck in (True, False):
        whole = optim.minimize(posed, seed=4, recheck=recheck)
        paused = optim.minimize(posed, seed=4, recheck=recheck, pause=1)
        snap = paused.extra["snapshot"]
        assert paused.stop == "paused" and snap.paused and paused.evaluations == snap.evaluations + 1
        assert paused.cost == pytest.approx(float(p.cost(paused.real[None, :], paused.bits[None, :])[0]))
        assert paused.evaluations < whole.evaluations
        assert 0.0 <= snap.gain <= 1.0                          # the race's best, gained over its last rung
        again = optim.minimize(posed, seed=4, recheck=recheck, resume=snap, pause=2)   # paused once more
        assert again.stop == "paused" and again.extra["snapshot"].race[1] == 2
        for done in (optim.minimize(posed, seed=4, recheck=recheck, resume=snap),
                     optim.minimize(posed, seed=4, recheck=recheck, resume=again.extra["snapshot"])):
            assert np.array_equal(done.real, whole.real) and np.array_equal(done.bits, whole.bits)
            assert done.cost == whole.cost and list(done.history) == list(whole.history)
            assert done.evaluations == whole.evaluations
            assert ("snapshot" in done.extra) == (not recheck)  # a first pass still leaves its final check
    with pytest.raises(ValueError, match="pause must be None or a whole number"):
        optim.minimize(posed, pause=-1)


def test_settling_left_for_later_is_done_by_the_check():
    """Designed: a first pass with ``settle_later`` converges its finalists but leaves their restarts
    (and revivals) to the continued run; its snapshot says so, it costs fewer evaluations than a
    settled first pass, and continued with the final check it ends settled, at least as well as the
    converged point and as the settled first pass continued."""
    p = synthetic.problem("abrupt+intermittent", 0)
    posed = optim.pose(p.cost, bounds=p.bounds(), n_bits=p.n_bits, onehot=p.onehot, structure=p.structure)
    settled = optim.minimize(posed, seed=4, recheck=False)
    later = optim.minimize(posed, seed=4, recheck=False, settle_later=True)
    assert settled.extra["snapshot"].settled and not later.extra["snapshot"].settled
    assert later.evaluations < settled.evaluations
    done = optim.minimize(posed, seed=4, resume=later.extra["snapshot"])
    whole = optim.minimize(posed, seed=4, resume=settled.extra["snapshot"])
    assert "snapshot" not in done.extra and done.evaluations > later.evaluations
    assert done.cost <= later.cost and done.cost <= whole.cost * (1 + 1e-3)
    assert synthetic.recovered(p.spaces, p.truth, p.finish(done.real, done.bits), done.bits, p.t, p.t0)


def test_compiled_de_trials_are_numpys_to_the_bit():
    """AHDE's DE/current-to-pbest/1/bin generation, on numpy and compiled (optim._jit): the same
    random draws in the same order, the same trial points, F and CR bit for bit (ties in the
    costs, points pushed out of bounds, one free real and several), and the generator left in the
    same state; on each compiled path this machine has (numba's, C's)."""
    from optim import kernels
    paths = kernels.available()
    if not paths:
        pytest.skip("no compiled path (numba or a C compiler)")
    draws = np.random.default_rng(9)
    for n, d, free in ((6, 3, [1]), (12, 5, [0, 2, 3, 4]), (30, 9, list(range(9)))):
        x = draws.uniform(-1.5, 1.5, (n, d))
        f = np.round(draws.random(n), 1)                            # ties: argsort's order decides pbest
        b = Branch("k", np.zeros(2, dtype=bool), np.array(free), x, f, draws.uniform(0.1, 1.0, n), draws.random(n))
        got = []
        for path in ["numpy", *paths]:
            before = kernels.use(path)
            try:
                assert kernels.path() == path
                e = AHDE(optim.pose(lambda r, bits: r.sum(axis=1), bounds=[[-1, 1]] * d, n_bits=2),
                         AHDEOptions(seed=4))
                got.append((e.trials(b), e.rng.bit_generator.state["state"]))
            finally:
                kernels.use(before)
        (plain, state_plain), *compiled = got
        for fast, state_fast in compiled:
            for a, c in zip(plain, fast):
                assert np.array_equal(a, c)
            assert state_plain == state_fast


def test_a_generation_drawn_in_c_is_numpys_to_the_bit():
    """AHDE's generation of several structures at once on the C path (optim._native.trials_batch:
    the random draws taken in C from numpy's own bit generator, Lemire's bounded integers included)
    against numpy's trials one structure after another: the same trial points, F and CR bit for
    bit, and the generator left in the same state. Populations of 3 (integers(1, 2) draws nothing),
    6, 10 and 40 points, with ties in the costs; the generator entered with half of a 64-bit draw
    buffered (its next 32-bit draw is that half)."""
    from optim import kernels
    if "c" not in kernels.available():
        pytest.skip("no C compiler")
    draws = np.random.default_rng(3)
    branches = []
    for n, d, free in ((3, 2, [0]), (6, 3, [1]), (10, 4, [0, 2, 3]), (40, 7, list(range(7)))):
        x = draws.uniform(-1.5, 1.5, (n, d))
        f = np.round(draws.random(n), 1)
        branches.append((d, Branch("k", np.zeros(2, dtype=bool), np.array(free), x, f, draws.uniform(0.1, 1.0, n),
                                   draws.random(n))))
    for seed in range(5):
        got = []
        for path in ("numpy", "c"):
            before = kernels.use(path)
            try:
                runs = []
                for d, b in branches:
                    e = AHDE(optim.pose(lambda r, bits: r.sum(axis=1), bounds=[[-1, 1]] * d, n_bits=2),
                             AHDEOptions(seed=seed))
                    e.rng.integers(0, 7, seed % 2)          # odd seeds: a 32-bit half left in the buffer
                    runs.append((e, b))
                # one engine's generator across the structures, as one generation of the race draws
                e0 = runs[-1][0]
                for e, _ in runs:
                    e.rng = e0.rng
                if path == "c":                             # the batch runs (no fall-back to one at a time)
                    assert kernels.path() == "c" and kernels.jit().trials_batch(
                        np.random.default_rng(0), [(b.x, b.free, b.F, b.CR, b.f.argsort(), *e0._limits(b.free))
                                                   for _, b in runs]) is not None
                made = e0.trials_of([b for _, b in runs]) if path == "c" else [e0.trials(b) for _, b in runs]
                got.append((made, e0.rng.bit_generator.state["state"], e0.rng.random()))
            finally:
                kernels.use(before)
        (plain, state_plain, next_plain), (fast, state_fast, next_fast) = got
        for a, c in zip(plain, fast):
            for u, v in zip(a, c):
                assert np.array_equal(u, v)
        assert state_plain == state_fast and next_plain == next_fast


def test_a_screen_evaluates_each_distinct_point_once_and_keeps_every_rows_cost():
    # the proposals repeat (a structure's unread real set to its midpoint makes them equal): each
    # distinct point is evaluated once, the costs of the screen are every row's, so the population
    # kept is the one a screen evaluating every row keeps, and the evaluations counted are the rows
    # evaluated
    seen = []

    def cost(real, bits):
        seen.extend(map(tuple, np.column_stack([real, bits])))
        return _sphere(real, bits)

    twice = np.array([[0.1, 0.2, 0.9], [0.1, 0.2, -0.9], [0.3, 0.3, 0.0], [0.1, 0.2, 0.0]])
    problem = optim.pose(cost, bounds=[[-1, 1]] * 3, n_bits=1, free=lambda b: np.array([True, True, False]),
                         propose=lambda b: twice)
    e = AHDE(problem, AHDEOptions(screen=40, screen_each=20))
    e.counter.objective = cost
    bits = np.array([True])
    (b,) = e.spawn([bits], screen=40)
    rows = e.counter.evaluations
    assert rows == len(seen) == len(set(seen))               # no point evaluated twice
    assert rows == 20 + 2          # 20 screen points and the proposals' 2 distinct ones (x3 at its midpoint)
    assert np.allclose(b.f, _sphere(b.x, np.ones((len(b.x), 1), dtype=bool)))
