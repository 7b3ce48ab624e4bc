"""Where the networks run: `--device` of the trainer and of the value-guided search.

The CPU is the default everywhere and the path every result so far was made on. `--device cuda` (or
`cuda:N`) puts the Q-network's arithmetic on a GPU: the trainer's online and target networks, their
minibatch forward and backward passes and the optimizer step (`learning.q.training`), or a value's batched
q_max and V_AP in the search (`learning.q.value.ValueFunction.to_device`). Everything else stays on the CPU:
the simulator, the replay memories, the target plans' bookkeeping, and acting (one row per step, where a
device's per-call latency would cost more than the arithmetic it saves), which reads a CPU copy of the
online weights refreshed after every update.
"""

from __future__ import annotations

import torch

from planning.errors import DomainError


def check_device(name: str | None) -> torch.device | None:
    """The torch device a `--device` names (None for None), or a one-line DomainError: not a device, a kind
    other than cpu or cuda, or CUDA asked for where this torch has none."""
    if name is None:
        return None
    try:
        device = torch.device(name)
    except RuntimeError:
        raise DomainError("--device", f"'{name}' is not a torch device (cpu, cuda or cuda:N)") from None
    if device.type not in ("cpu", "cuda"):
        raise DomainError("--device", f"'{name}': only cpu and cuda are supported")
    if device.type == "cuda":
        if not torch.cuda.is_available():
            why = "this torch is built without CUDA" if torch.version.cuda is None else "no CUDA device is visible"
            raise DomainError("--device", f"'{name}': {why} (torch {torch.__version__})")
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise DomainError("--device", f"'{name}': this machine has {torch.cuda.device_count()} CUDA device(s)")
    return device
