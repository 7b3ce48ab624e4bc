"""A trained Q-network as a value of the protocol (`planning.value`): greedy actions, q_max and v_ap, batched.

The batched plug-in calls for searches (SPEC "Values as plug-in heuristics") are
`ValueFunction.q_max(states, task)` and `ValueFunction.v_ap(states)`.
"""

from __future__ import annotations

import numpy as np

from learning.encoding import Encoding
from planning.errors import DomainError

from .checkpoints import check_domain, checkpoint_config, read_checkpoint
from .inference import BatchedQ, NativeQ, NumpyQ, _qnet_lib
from .network import FactoredQNet

CHUNK = 8192
"""Rows per torch evaluation on a device (`ValueFunction.to_device`)."""


class ValueFunction:
    """A trained Q-network bound to a layout's encoding: greedy actions, q_max and v_ap, batched.

    Inference runs on numpy snapshots of the weights taken at construction:
    `NumpyQ` for every action's Q (q_values, greedy), `BatchedQ` for the maxima
    the searches ask for (q_max, v_ap); `native_q_max` hands the Bellman–Novelty
    search the compiled q_max (`NativeQ`), built on first use.
    """

    def __init__(self, net: FactoredQNet, enc: Encoding, gamma: float = 0.97):
        """`gamma`: the discount the network was trained with (the search discounts its prefix costs by it)."""
        self.net, self.enc, self.gamma = net, enc, gamma
        self.fast = NumpyQ(net)
        self.batched = BatchedQ(net, enc)
        self._native, self.memo, self._distribution = None, True, None
        self.device, self.on_device = None, None  # `to_device`: torch on a device instead of numpy and C

    def to_device(self, device) -> "ValueFunction":
        """q_max and V_AP evaluated by the network in torch on `device` (`learning.device`: cuda, or cpu for
        torch's own CPU kernels) instead of the numpy and compiled engines, in chunks of `CHUNK` rows; the
        compiled search then calls `q_max` (no `native_q_max`). The same values to float32 rounding, so a
        near-tie between two terminals may break the other way. Returns self."""
        import copy

        from learning.device import check_device

        self.device = check_device(device)
        self.on_device = copy.deepcopy(self.net).to(self.device).eval()
        return self

    def _max_q(self, packed: np.ndarray, tasks: np.ndarray) -> np.ndarray:
        """max_a Q(s, τ, a) of (packed state, task) rows, in torch on `device`."""
        import torch

        out = np.empty(len(packed))
        for lo in range(0, len(packed), CHUNK):
            p, t = packed[lo : lo + CHUNK], tasks[lo : lo + CHUNK]
            obs = torch.from_numpy(self.enc.observe(p, t)).to(self.device)
            valid = torch.from_numpy(self.enc.valid_for(p, t)).to(self.device)
            with torch.inference_mode():
                out[lo : lo + len(p)] = self.on_device(obs, valid).max(1).values.double().cpu().numpy()
        return out

    @classmethod
    def load(cls, path, model) -> "ValueFunction":
        """The value registry's hook (`learning.values`): the value of a learning.dqn checkpoint."""
        if path is None:
            raise DomainError("--value", "q-network needs a checkpoint: q-network:PATH")
        return load_value_function(path, model)

    @staticmethod
    def record(path) -> dict:
        """What a results file records of the checkpoint (`checkpoint_config`)."""
        return checkpoint_config(path)

    @property
    def native(self) -> "NativeQ | None":
        """The compiled engine, or None where there is no C compiler (or QNET_NATIVE=0) or the value runs on a
        device (`to_device`)."""
        if self.device is not None:
            return None
        if self._native is None:
            lib = _qnet_lib()
            self._native = NativeQ(self.batched, lib, self.memo) if lib is not None else False
            if self._native and self._distribution is not None:
                self._native.set_distribution(self._distribution)
        return self._native or None

    def set_distribution(self, probabilities) -> None:
        """V_AP's task distribution from now on: (instances,) P(τ') of a distribution estimator
        (`planning.world.estimators`), or None for the layout's P (the thesis's). V_AP(s) becomes
        Σ_τ' P(τ') max_a Q(s, τ', a) over the support; off-support mass must be 0."""
        p = None if probabilities is None else np.asarray(probabilities, dtype=np.float64)
        if p is not None and (
            p.shape != (len(self.enc.task_prob),) or p[~np.isin(np.arange(len(p)), self.enc.support)].any()
        ):
            raise DomainError("estimator", "a task distribution over the layout's tasks, zero off the support of P")
        self._distribution = None if p is None else p[self.enc.support]
        prob = self.enc.task_prob[self.enc.support] if p is None else self._distribution
        self.batched.set_distribution(prob)
        if self._native:
            self._native.set_distribution(prob)

    def set_memo(self, on: bool) -> None:
        """Keep the compiled engine's values across calls (the default) or not (a fresh engine either way)."""
        self.memo, self._native = bool(on), None

    def native_q_max(self, task):
        """For `planning.search.bellman_novelty`: an object whose `fn` and `ctx` are the compiled q_max of
        this network (`bn_native_fn` of planning/search/_bn.c, task = task.index), or None."""
        return self.native

    def q_values(self, states, task) -> np.ndarray:
        """(N, actions) Q of (state, task) for every ground action and AUTO; -inf where invalid."""
        packed = self.enc.pack(states)
        tasks = np.full(len(packed), _task_index(task), dtype=np.int64)
        return self.fast(self.enc.observe(packed, tasks), self.enc.valid_for(packed, tasks))

    def greedy(self, states, task) -> np.ndarray:
        """The greedy ground action (or AUTO) per state for one task."""
        return self.q_values(states, task).argmax(1)

    def q_max(self, states, task) -> np.ndarray:
        """max_a Q(s, τ, a) per state: the value of a state for the current task."""
        if self.device is not None:
            packed = self.enc.pack(states)
            return self._max_q(packed, np.full(len(packed), _task_index(task), dtype=np.int64))
        return self.batched.q_max(states, _task_index(task))

    def v_ap(self, states) -> np.ndarray:
        """V_AP(s) = Σ_τ P(τ) max_a Q(s, τ, a) per state: the preparedness value (Eq. 3.8)."""
        if self.device is not None:
            packed, support = self.enc.pack(states), self.enc.support
            n, k = len(packed), len(support)
            rows = np.repeat(np.arange(n), k)
            q = self._max_q(packed[rows], np.tile(support, n).astype(np.int64)).reshape(n, k)
            prob = self.enc.task_prob[support] if self._distribution is None else self._distribution
            return q @ prob
        return self.batched.v_ap(states)


def _task_index(task) -> int:
    return task if isinstance(task, (int, np.integer)) else task.index


def load_value_function(path, model) -> ValueFunction:
    """The greedy value of a checkpoint, checked against the layout it is used on."""
    return value_function(read_checkpoint(path), model, path)


def value_function(payload: dict, model, path="checkpoint") -> ValueFunction:
    """The greedy value of a loaded checkpoint payload (float32 weights), checked against the layout and
    the domain (`check_domain`); `path` names it in errors."""
    check_domain(path, payload, model)
    sig = payload.get("signature", {})
    enc = Encoding(model, sig.get("task_features", "arguments"))  # the encoding it was trained with
    mine = enc.signature()
    if sig != mine:
        diff = [k for k in mine if sig.get(k) != mine[k]]
        raise DomainError(
            path,
            f"trained for {sig.get('domain')}/{sig.get('layout')}, "
            f"not {mine['domain']}/{mine['layout']} (differs in {', '.join(diff)})",
        )
    d = payload["dims"]
    net = FactoredQNet(d["obs_dim"], enc.labels, d["vocab_sizes"], d["hidden"], d["embed"], d["head_hidden"])
    try:
        net.load_state_dict(payload["net"])
    except RuntimeError as e:
        raise DomainError(path, f"weights do not fit the network ({str(e).splitlines()[0]})") from None
    net.eval()
    return ValueFunction(net, enc, float(payload.get("config", {}).get("gamma", 0.97)))
