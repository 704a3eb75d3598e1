"""rostpy's API over rost (docs/python.md, "rostpy's names next to ours").

A script written for rostpy (rost-cli's Python bindings) runs when its import
becomes `import rost.rostpy as rostpy`:

    model = rostpy.ROST_t(V=200, K=5, alpha=0.1, beta=0.5, gamma=0)
    for t, words in enumerate(documents):
        model.add_observation([t], words)          # lists or arrays
    for _ in range(60):
        rostpy.parallel_refine(model, 2)           # one sweep over every cell
    labels = model.get_ml_topics_for_pose([0])     # one label per word, in order

rost refines whole time steps, and its Config is fixed when its model is made,
so the classes here collect what add_observation brings and hand it to a
rost.Model, one time step per observation, when a refinement or a question
needs it (the first such call makes the model, sized from what was added;
keywords of rost.Config given to the constructor override that). What rost
cannot serve raises NotImplementedError or ValueError naming the method and why.
"""

import math

import numpy as np

from ._rost import Config, Model

__all__ = ["ROST_t", "ROST_txy", "ROST_xy", "parallel_refine", "parallel_refine_tau"]


def _unsupported(name, why):
    raise NotImplementedError(f"rost.rostpy: {name} is not served: {why}")


def _ints(values, what):
    """A 1-D int64 array of `values` (a list, tuple or integer array)."""
    a = np.asarray(values)
    if a.size == 0:
        return np.zeros(0, dtype=np.int64)
    if a.ndim != 1 or a.dtype.kind not in "iu":
        raise TypeError(f"rost.rostpy: {what}: expected a list or 1-D array of integers, found {values!r:.60}")
    return a.astype(np.int64)


class _Step:
    """One time step being collected: its words, positions and the words of each pose."""

    def __init__(self, key):
        self.key = key
        self.words = []
        self.positions = []
        self.size = 0
        self.cells = {}

    def add(self, words, cell):
        first = self.size
        self.words.append(words)
        self.positions.append(np.tile(np.asarray(cell, dtype=np.int64), (len(words), 1)))
        self.size += len(words)
        self.cells[cell] = self.cells.get(cell, 0) + len(words)
        return range(first, self.size)


class _ROST:
    """What ROST_t, ROST_txy and ROST_xy share; a subclass says what a pose is."""

    _pose_lengths = ()
    _spatial = True

    def __init__(self, V, K, alpha, beta, gamma, **settings):
        if not gamma >= 0:  # NaN too: it would be neither a fixed K nor growth
            raise ValueError(f"rost.rostpy: gamma = {gamma}: expected 0 (a fixed K) or more (topics grow)")
        self.V, self.K = int(V), int(K)
        self.alpha, self.beta, self.gamma = float(alpha), float(beta), float(gamma)
        self._grow = self.gamma > 0
        self._settings = dict(settings)
        Config(V=self.V, K=self.K, alpha=self.alpha, beta=self.beta, **self._settings)  # checked now
        self._model = None
        self._fixed = None  # decided by the first add_observation's update_model
        self._counts = None  # set_topic_model's before the model is made
        self._steps = []  # every time step, in order; the first _handed are in the model
        self._handed = 0
        self._where = {}  # pose key -> [(step, word indices)]
        self._cells = []  # pose keys in order of first appearance (cell ids)
        self._poses_by_time = {}
        self._refines = 0
        self._word_refines = 0
        self._origin = (0, 0)

    # ---- poses ------------------------------------------------------------
    def _pose(self, pose, name):
        p = _ints(pose, f"{name}: pose")
        if len(p) not in self._pose_lengths:
            lengths = " or ".join(str(n) for n in self._pose_lengths)
            raise ValueError(f"rost.rostpy.{type(self).__name__}.{name}: a pose has {lengths} coordinates "
                             f"({self._pose_help}), found {list(p)}")
        return tuple(int(x) for x in p)

    def _step_key(self, pose):  # the time step a new pose joins (ROST_t, ROST_txy: its t)
        return pose[0]

    def _cell(self, pose):  # (x, y) of the pose's words in rost's grid
        return (0, 0) if len(pose) == 1 else pose[-2:]

    def _key(self, pose):  # what identifies the pose's words
        return pose

    # ---- adding -----------------------------------------------------------
    def add_observation(self, pose, words, topics=None, update_model=True):
        """Adds `words` (ids in [0, V)) at `pose`; update_model=False labels them with a fixed topic model."""
        if isinstance(topics, (bool, np.bool_)):  # rostpy's add_observation(pose, words, update_model)
            topics, update_model = None, topics
        if topics is not None and len(topics) > 0:
            _unsupported("add_observation with topics", "rost.Model draws each word's initial topic itself")
        pose = self._pose(pose, "add_observation")
        w = _ints(words, "add_observation: words")
        bad = np.flatnonzero((w < 0) | (w >= self.V))
        if len(bad):
            raise ValueError(f"rost.rostpy.add_observation: words[{bad[0]}] = {w[bad[0]]} is outside [0, V = {self.V})")
        self._mode(bool(update_model), "add_observation")
        step = self._open_step(pose)
        try:
            cell = self._cell(pose)
            if self._model is not None:
                self._check_fits(step, cell, len(w))
        except ValueError:
            if not step.words and step is self._steps[-1]:
                self._steps.pop()  # a refused add leaves no empty time step behind (it would shift the neighbours)
            raise
        indices = step.add(w, cell)
        key = self._key(pose)
        if key not in self._where:
            self._where[key] = []
            self._cells.append(key)
        self._where[key].append((len(self._steps) - 1, indices))
        at = self._poses_by_time.setdefault(pose[0] if len(pose) != 2 else len(self._steps) - 1, [])
        if list(pose) not in at:
            at.append(list(pose))

    def addObservations(self, pose, words, topics=(), update_model=True):  # noqa: N802 (rostpy's name)
        """rostpy's other spelling of add_observation."""
        self.add_observation(pose, words, topics, update_model)

    def _mode(self, update_model, name):
        if self._fixed is None:
            self._fixed = not update_model
        elif self._fixed == update_model:
            was = "fixed (update_model=False)" if self._fixed else "learning (update_model=True)"
            raise ValueError(f"rost.rostpy.{name}: update_model={update_model}, but this model is {was}: "
                             "a rost model either learns its topic model or keeps it fixed, from its first observation on")

    def _open_step(self, pose):
        key = self._step_key(pose)
        last = self._steps[-1] if self._steps else None
        if last is not None and last.key == key and len(self._steps) > self._handed:
            return last
        if last is not None and key is not None and key <= last.key:
            why = ("repeats the time of a step rost already holds (rost takes a time step whole: add all of a "
                   "time's words before refining or asking for results)" if key == last.key
                   else f"goes back in time (the latest is t = {last.key}; rost's time steps follow each other)")
            raise ValueError(f"rost.rostpy.{type(self).__name__}.add_observation: t = {key} {why}")
        self._steps.append(_Step(key))
        return self._steps[-1]

    def _check_fits(self, step, cell, n):
        c = self._model.config
        x, y = cell[0] - self._origin[0], cell[1] - self._origin[1]
        if not (0 <= x < c.frame_width and 0 <= y < c.frame_height):
            raise ValueError(f"rost.rostpy.add_observation: (x, y) = {cell} lies outside the grid the model was made "
                             f"with (x in [{self._origin[0]}, {self._origin[0] + c.frame_width}), y in "
                             f"[{self._origin[1]}, {self._origin[1] + c.frame_height})); give frame_width and "
                             "frame_height to the constructor")
        if step.size + n > c.max_words or step.cells.get(cell, 0) + n > c.cell_capacity:
            raise ValueError(f"rost.rostpy.add_observation: a time step of more than max_words = {c.max_words} "
                             f"words or a cell of more than cell_capacity = {c.cell_capacity} (the model's, made "
                             "from what came before); give larger ones to the constructor")

    # ---- the rost model -----------------------------------------------------
    def _config(self):
        """The rost.Config, sized from the steps collected (unless the constructor's keywords say)."""
        longest = max((s.size for s in self._steps), default=0)
        fullest = max((n for s in self._steps for n in s.cells.values()), default=0)
        cells = [c for s in self._steps for c in s.cells] or [(0, 0)]
        self._origin = (min(0, min(c[0] for c in cells)), min(0, min(c[1] for c in cells)))
        kw = dict(V=self.V, K=self.K, alpha=self.alpha, beta=self.beta, cell_space=1,
                  frame_width=max(c[0] for c in cells) - self._origin[0] + 1,
                  frame_height=max(c[1] for c in cells) - self._origin[1] + 1,
                  ring_steps=max(2 * len(self._steps), 256), max_words=max(2 * longest, 256),
                  cell_capacity=max(2 * fullest, 64), sampler="uniform")
        if self._grow:
            kw.update(topics_grow=True, gamma=self.gamma)
        if self._fixed:
            kw["topicmodel_fixed"] = True
        kw.update(self._settings)
        return Config(**kw)

    def _sync(self):
        """Makes the model if there is none and hands it the time steps collected."""
        if self._model is None:
            self._model = Model(self._config())
            if self._counts is not None:
                self._model.set_topic_model(self._counts)
        for i in range(self._handed, len(self._steps)):
            s = self._steps[i]
            words = np.concatenate(s.words).astype(np.int32) if s.words else np.zeros(0, np.int32)
            pos = np.concatenate(s.positions) - np.asarray(self._origin) if s.words else np.zeros((0, 2))
            self._model.add_observation(i, words, np.ascontiguousarray(pos, dtype=np.int32) if self._spatial else None)
        self._handed = len(self._steps)
        return self._model

    def _labels(self, pose, ml, name):
        key = self._key(self._pose(pose, name))
        if key not in self._where:
            raise KeyError(f"rost.rostpy.{name}: no words at pose {list(pose)}")
        m = self._sync()
        out = []
        for step, indices in self._where[key]:
            z = m.ml_topics(step) if ml else m.topics(step)
            out.extend(int(z[i]) for i in indices)
        return out

    # ---- results ------------------------------------------------------------
    def get_topics_for_pose(self, pose):
        """The current Gibbs sample of the pose's words, one topic a word in the order they were added."""
        return self._labels(pose, False, "get_topics_for_pose")

    def get_ml_topics_for_pose(self, pose, update_ppx=False):
        """The maximum-likelihood topic of the pose's words, one a word in the order they were added."""
        return self._labels(pose, True, "get_ml_topics_for_pose")

    def computeMaxLikelihoodTopics(self, pose):  # noqa: N802 (rostpy's name)
        return self.get_ml_topics_for_pose(pose)

    def get_topics_and_ppx_for_pose(self, pose):
        """(Gibbs topics, log-likelihood of the pose's words) as rostpy returns them."""
        z = self.get_topics_for_pose(pose)
        return z, self._log_likelihood(pose, z)

    def get_ml_topics_and_ppx_for_pose(self, pose):
        """(maximum-likelihood topics, log-likelihood of the pose's words)."""
        z = self.get_ml_topics_for_pose(pose)
        return z, self._log_likelihood(pose, z)

    def estimate_cell(self, cell_id, update_ppx=False):
        """The maximum-likelihood topics of cell `cell_id` (cells numbered in order of first appearance)."""
        if not 0 <= cell_id < len(self._cells):
            raise IndexError(f"rost.rostpy.estimate_cell: cell_id = {cell_id}, there are {len(self._cells)} cells")
        return self._labels(list(self._cells[cell_id]), True, "estimate_cell")

    def get_topic_model(self):
        """n_k^v as a K x V list of lists."""
        return self._topic_model().tolist()

    def _topic_model(self):
        if self._model is None and self._handed == len(self._steps):
            return np.zeros((self.K, self.V), np.int64) if self._counts is None else self._counts.copy()
        return self._sync().topic_model().astype(np.int64)

    def get_topic_weights(self):
        """n_k: the words of each topic (a list of K)."""
        return [int(x) for x in self._topic_model().sum(axis=1)]

    def set_topic_model(self, topic_model):
        """Sets n_k^v (a K x V list of lists, or an array) before the model holds words."""
        counts = np.asarray(topic_model)
        if counts.shape != (self.K, self.V) or (counts.size and counts.dtype.kind not in "iu"):
            raise ValueError(f"rost.rostpy.set_topic_model: expected K x V = {self.K} x {self.V} integer counts, "
                             f"found shape {counts.shape}")
        if self._model is not None:
            raise ValueError("rost.rostpy.set_topic_model: the model already holds observations; rost adds a topic "
                             "model as a prior on a fresh model (call set_topic_model before refining or asking for "
                             "results)")
        self._counts = counts.astype(np.int64)

    def set_topic_model_flat(self, topic_model, topic_weights=None):
        """set_topic_model with the K x V counts flattened row by row."""
        self.set_topic_model(np.asarray(topic_model).reshape(self.K, self.V))

    # ---- perplexities (rost's per time step; per word from the topic model) --
    def _phi(self):
        """p(w | k): (n_k^v + beta) / (n_k + V beta), K x V."""
        n = self._topic_model().astype(np.float64)
        return (n + self.beta) / (n.sum(axis=1, keepdims=True) + self.V * self.beta)

    def _word_ids(self, words, what):
        """`words` as int64 ids, each in [0, V): a negative id must not index phi from its end."""
        w = _ints(words, what)
        bad = np.flatnonzero((w < 0) | (w >= self.V))
        if len(bad):
            raise ValueError(f"rost.rostpy.{what}[{bad[0]}] = {w[bad[0]]} out of range [0, {self.V})")
        return w

    def _topic_counts(self, counts, what):
        """Topic counts (K of them, or none: zeros) as float64; another length is refused, not cut or broadcast."""
        if counts is None or len(counts) == 0:
            return np.zeros(self.K)
        c = np.asarray(counts, dtype=np.float64)
        if c.shape != (self.K,):
            raise ValueError(f"rost.rostpy.{what}: expected K = {self.K} topic counts, found shape {c.shape}")
        return c

    def _word_probabilities(self, words, nZ, what="words"):
        """p(w) = sum_k theta_k p(w | k) for each word, theta from the topic counts nZ and alpha."""
        nz = self._topic_counts(nZ, "nZ")
        theta = (nz + self.alpha) / (nz.sum() + self.K * self.alpha)
        return theta @ self._phi()[:, self._word_ids(words, what)]

    def _pose_words(self, pose, name):
        key = self._key(self._pose(pose, name))
        if key not in self._where:
            raise KeyError(f"rost.rostpy.{name}: no words at pose {list(pose)}")
        return np.concatenate([np.concatenate(self._steps[s].words)[list(i)] for s, i in self._where[key]])

    def _log_likelihood(self, pose, z):
        words = self._pose_words(pose, "perplexity")
        p = self._word_probabilities(words, np.bincount(np.asarray(z, dtype=np.int64), minlength=self.K))
        return float(np.log(p).sum())

    def word_perplexity(self, pose, recompute=False):
        """Each word's perplexity 1 / p(w) under the topic model and the pose's topic mix (its Gibbs sample)."""
        words = self._pose_words(pose, "word_perplexity")
        z = self.get_topics_for_pose(pose)
        p = self._word_probabilities(words, np.bincount(np.asarray(z, dtype=np.int64), minlength=self.K))
        return [float(x) for x in 1.0 / p]

    def cell_perplexity_word(self, words, nZ):
        """exp(-mean log p(w)) of `words` under the topic model and the topic counts nZ."""
        p = self._word_probabilities(words, nZ, "cell_perplexity_word: words")
        return float(math.exp(-np.log(p).mean())) if len(p) else float("nan")

    def time_perplexity(self, t, recompute=False):
        """The perplexity of time t's step (rost's, word left out; docs/design.md)."""
        steps = [i for i, s in enumerate(self._steps) if s.key == t]
        if not steps:
            raise KeyError(f"rost.rostpy.time_perplexity: no observation at t = {t}")
        return float(self._sync().perplexity(steps[0]))

    def perplexity(self, pose=None, recompute=False):
        """perplexity(): of the whole window; perplexity(pose): of the pose's time step (ROST_t)."""
        if pose is None or isinstance(pose, (bool, np.bool_)):
            return float(self._sync().perplexity())
        return self._pose_perplexity(self._pose(pose, "perplexity"))

    def _pose_perplexity(self, pose):
        _unsupported(f"{type(self).__name__}.perplexity(pose)", "rost measures perplexity per time step, not per "
                     "cell: use time_perplexity(t), or word_perplexity(pose)")

    # ---- refinement -----------------------------------------------------------
    def _refined(self, tokens, cells):
        self._refines += cells
        self._word_refines += int(tokens)

    def refine_ext(self, words, n_iter=10, nZg=()):
        """Gibbs-samples topics for `words` against the topic model without adding them (n_iter sweeps;
        nZg: topic counts of a neighbourhood added to the words' own). Seeded: the model's seed and call."""
        w = self._word_ids(words, "refine_ext: words")
        phi = self._phi()
        prior = self._topic_counts(nZg, "refine_ext: nZg")
        rng = np.random.default_rng([int(self._settings.get("seed", 1)), self._word_refines, len(w)])
        z = rng.integers(0, self.K, size=len(w))
        nz = np.bincount(z, minlength=self.K).astype(np.float64)
        for _ in range(int(n_iter)):
            for i, v in enumerate(w):
                nz[z[i]] -= 1
                p = (nz + prior + self.alpha) * phi[:, v]
                z[i] = int(np.searchsorted(np.cumsum(p), rng.random() * p.sum(), side="right"))
                z[i] = min(z[i], self.K - 1)
                nz[z[i]] += 1
        return [int(x) for x in z]

    def refine_cell(self, cell_id, blocking=True):
        _unsupported("refine_cell", "rost refines whole time steps, drawn by its sampler or swept: use "
                     "parallel_refine(model, nt) or parallel_refine_tau(model, nt, tau, iter)")

    def refine_pose(self, pose, blocking=True):
        _unsupported("refine_pose", "rost refines whole time steps, drawn by its sampler or swept: use "
                     "parallel_refine(model, nt) or parallel_refine_tau(model, nt, tau, iter)")

    def forget(self, cell_id=-1):
        _unsupported("forget", "rost forgets whole time steps as they leave its window of ring_steps steps "
                     "(give ring_steps and eviction='subtract' to the constructor)")

    def add_count(self, w, z, c=1):
        _unsupported("add_count", "rost's counts change only through its observations and set_topic_model")

    def relabel(self, w, z_old, z_new):
        _unsupported("relabel", "rost's counts change only through its observations and set_topic_model")

    def shuffle_topics(self):
        _unsupported("shuffle_topics", "rost draws the initial topics itself, seeded")

    def update_gamma(self):
        _unsupported("update_gamma", "rost learns gamma from the data at every growth move (docs/design.md, 'Growth from the data')")

    def topic_perplexity(self, pose):
        _unsupported("topic_perplexity", "rost measures word perplexity (time_perplexity, word_perplexity)")

    def word_topic_perplexity(self, pose):
        _unsupported("word_topic_perplexity", "rost measures word perplexity (time_perplexity, word_perplexity)")

    def cell_perplexity_topic(self, nZ):
        _unsupported("cell_perplexity_topic", "rost measures word perplexity (cell_perplexity_word)")

    def enable_auto_topics_size(self, enabled=True):
        """Topic growth on or off, before the model is made (gamma > 0 turns it on at construction)."""
        if self._model is not None and bool(enabled) != self._grow:
            raise ValueError("rost.rostpy.enable_auto_topics_size: the model is made; rost fixes topic growth then")
        if enabled and self.gamma <= 0:
            raise ValueError("rost.rostpy.enable_auto_topics_size: topics grow with gamma > 0 (this model's is 0)")
        self._grow = bool(enabled)

    # ---- counters and properties ------------------------------------------------
    def num_cells(self):
        """Poses (cells) that hold words."""
        return len(self._cells)

    def get_num_words(self):
        """The vocabulary size V, as rostpy's."""
        return self.V

    def get_refine_count(self):
        return self._refines

    def get_word_refine_count(self):
        return self._word_refines

    def get_poses_by_time(self):
        """{t: [pose, ...]}: the poses added at each time (ROST_xy's [x, y] poses: at their step)."""
        return {t: [list(p) for p in poses] for t, poses in self._poses_by_time.items()}

    @property
    def betaV(self):  # noqa: N802 (rostpy's name)
        return self.beta * self.V

    @property
    def active_K(self):  # noqa: N802 (rostpy's name)
        return self.K if self._model is None and not self._grow else self._sync().active_topics

    @property
    def update_global_model(self):
        return not self._fixed

    @update_global_model.setter
    def update_global_model(self, value):
        self._mode(bool(value), "update_global_model")

    @property
    def g_sigma(self):
        return getattr(self, "_g_sigma", None)

    @g_sigma.setter
    def g_sigma(self, value):
        # rostpy's README sets it first thing: kept, not served, said once, so the script goes on.
        import warnings
        if getattr(self, "_g_sigma", None) is None:
            warnings.warn("rost.rostpy: g_sigma is kept but not used: rost's neighbourhood is g_space cells and g_time "
                          "steps, weighted alike (give g_space, g_time to the constructor)", RuntimeWarning, stacklevel=2)
        self._g_sigma = float(value)

    @property
    def model(self):
        """The rost.Model behind it (made, and handed what was added, on first use)."""
        return self._sync()

    def __repr__(self):
        return (f"rost.rostpy.{type(self).__name__}(V={self.V}, K={self.K}, alpha={self.alpha}, beta={self.beta}, "
                f"gamma={self.gamma}, cells={len(self._cells)})")


class ROST_t(_ROST):  # noqa: N801 (rostpy's name)
    """Poses [t], one observation (one rost time step) each; t any integers that increase."""

    _pose_lengths = (1,)
    _pose_help = "[t]"
    _spatial = False

    def _pose_perplexity(self, pose):
        return self.time_perplexity(pose[0])


class ROST_txy(_ROST):  # noqa: N801 (rostpy's name)
    """Poses [t, x, y]: a time t's poses form one rost time step, (x, y) its cells."""

    _pose_lengths = (3,)
    _pose_help = "[t, x, y]"


class ROST_xy(_ROST):  # noqa: N801 (rostpy's name)
    """Poses [t, x, y] (t ignored, as rostpy's) or [x, y]: a cell is (x, y) for all time; what is added
    between two refinements (or questions) forms one rost time step."""

    _pose_lengths = (2, 3)
    _pose_help = "[t, x, y] or [x, y]"

    def _step_key(self, pose):
        return None

    def _key(self, pose):
        return pose[-2:]

    def time_perplexity(self, t, recompute=False):
        _unsupported("ROST_xy.time_perplexity", "ROST_xy ignores time (use perplexity())")


def _threads(nt, name):
    if isinstance(nt, (bool, np.bool_)) or int(nt) != nt or not 1 <= nt <= 1024:
        raise ValueError(f"rost.rostpy.{name}: nt = {nt!r}: threads in [1, 1024]")
    return int(nt)


def parallel_refine(rost, nt=1):
    """One Gibbs sweep over every cell of `rost` on `nt` threads (the result does not depend on nt)."""
    m = rost._sync()
    rost._refined(m.parallel_refine(_threads(nt, "parallel_refine"), 1), rost.num_cells())


def parallel_refine_tau(rost, nt, tau, iter):  # noqa: A002 (rostpy's name)
    """`iter` time steps refined, drawn by rost's sampler (the constructor's `sampler`, default "uniform":
    rostpy's tau = 1). rost draws steps by its sampler, not by Beta(tau, 1) over cells: another tau needs
    the sampler given at construction, and is then not used."""
    if not tau > 0:
        raise ValueError(f"rost.rostpy.parallel_refine_tau: tau = {tau}, expected > 0")
    if tau != 1 and "sampler" not in rost._settings:
        raise ValueError(f"rost.rostpy.parallel_refine_tau: tau = {tau} (Beta(tau, 1) over cells) has no rost "
                         "counterpart: rost draws time steps by its sampler; choose one at construction "
                         "(sampler='agep' favours the newer steps, 'exp' the newest) and tau is then not used")
    _threads(nt, "parallel_refine_tau")
    m = rost._sync()
    rost._refined(m.refine(steps=int(iter)), int(iter))
