"""FlatAdam: the same steps as torch's per-parameter Adam with clipping, and checkpoints in its format."""

import torch
from torch import nn

from learning.q.optim import FlatAdam


def _net(seed=0):
    torch.manual_seed(seed)
    return nn.Sequential(nn.Linear(7, 16), nn.ReLU(), nn.Linear(16, 5), nn.ReLU(), nn.Linear(5, 3))


def _loss(net, x):
    # the last layer is left out of the loss half the time: its parameters must still step (zero grad)
    h = net[3](net[2](net[1](net[0](x))))
    return (h**2).sum() if x.shape[0] % 2 else (net[4](h) ** 3).sum()


def _reference_step(net, opt, x, clip):
    opt.zero_grad(set_to_none=True)
    _loss(net, x).backward()
    for p in net.parameters():
        if p.grad is None:
            p.grad = torch.zeros_like(p)
    torch.nn.utils.clip_grad_norm_(list(net.parameters()), clip)
    opt.step()


def test_flat_adam_steps_as_torch_adam_per_parameter():
    a, b = _net(), _net()
    ref = torch.optim.Adam(a.parameters(), lr=1e-2, fused=True)
    flat = FlatAdam(b.parameters(), lr=1e-2)
    gen = torch.Generator().manual_seed(1)
    for k in range(30):
        x = torch.randn(4 + k % 2, 7, generator=gen)
        _reference_step(a, ref, x, clip=0.5)  # clipping active: the norms are well above 0.5
        flat.zero_grad()
        _loss(b, x).backward()
        flat.step(0.5)
    for p, q in zip(a.parameters(), b.parameters()):
        torch.testing.assert_close(p, q, rtol=1e-5, atol=1e-6)
    # the module's parameters are views of the flat buffer: what the optimizer wrote is what the module uses
    assert b[0].weight.data_ptr() == flat.flat.data_ptr()
    # the checkpoint format is torch's: each optimizer resumes from the other's state
    ref_sd, flat_sd = ref.state_dict(), flat.state_dict()
    assert ref_sd["state"].keys() == flat_sd["state"].keys()
    for i, s in ref_sd["state"].items():
        assert float(s["step"]) == float(flat_sd["state"][i]["step"]) == 30
        for key in ("exp_avg", "exp_avg_sq"):
            torch.testing.assert_close(s[key], flat_sd["state"][i][key], rtol=1e-4, atol=1e-7)
    c = _net()
    resumed = FlatAdam(c.parameters(), lr=1e-2)
    resumed.load_state_dict(ref_sd)
    c.load_state_dict(a.state_dict())  # in place: into the flat buffer
    ref2 = torch.optim.Adam(a.parameters(), lr=1e-2, fused=True)
    ref2.load_state_dict(flat_sd)
    x = torch.randn(5, 7, generator=gen)
    _reference_step(a, ref, x, clip=0.5)
    resumed.zero_grad()
    _loss(c, x).backward()
    resumed.step(0.5)
    for p, q in zip(a.parameters(), c.parameters()):
        torch.testing.assert_close(p, q, rtol=1e-5, atol=1e-6)
    assert float(resumed.state_dict()["state"][0]["step"]) == 31
