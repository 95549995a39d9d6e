"""Evidence for the sine networks of ``pcgeom.nets``.

Shapes, positivity of the inverse-lambda net, the SIREN initialization bounds (Sitzmann et
al.: first layer U(-1/in, 1/in), hidden layers U(-sqrt(6/width), sqrt(6/width)) for
``sin(W h + b)``), forward passes against a hand-written reference, and
``torch.autograd.gradcheck`` in float64.
"""

from __future__ import annotations

import math

import pytest
import torch
from torch.func import functional_call

from pcgeom.config import NetConfig
from pcgeom.nets import DeformNet, LambdaInvNet, ParamNet, SineMLP


def _reference_forward(net: SineMLP, x: torch.Tensor, first_scale: float) -> torch.Tensor:
    """``sin(s (W_0 x + b_0))``, then ``sin(W_k h + b_k)``, then a linear output, by hand."""
    h = x
    for k, layer in enumerate(net.hidden):
        z = h @ layer.weight.T + layer.bias
        h = torch.sin(first_scale * z if k == 0 else z)
    return h @ net.out.weight.T + net.out.bias


# --------------------------------------------------------------------------- shapes


def test_param_net_maps_points_to_the_plane():
    torch.manual_seed(0)
    net = ParamNet(NetConfig(width=32, depth=3))
    y = net(torch.randn(17, 3))
    assert y.shape == (17, 2)
    assert torch.isfinite(y).all()


def test_lambda_inv_net_is_positive_and_one_value_per_point():
    torch.manual_seed(0)
    net = LambdaInvNet(NetConfig(width=16, depth=2))
    x = 3.0 * torch.randn(500, 3)
    lam = net(x)
    assert lam.shape == (500,)
    assert (lam > 0).all()
    # It is softplus of the body's single output.
    torch.testing.assert_close(lam, torch.nn.functional.softplus(net.body(x))[:, 0])


def test_lambda_inv_net_stays_positive_when_the_body_is_very_negative():
    net = LambdaInvNet(NetConfig(width=4, depth=1))
    with torch.no_grad():
        net.body.out.weight.zero_()
        net.body.out.bias.fill_(-30.0)  # softplus(-30) ~ 1e-13, still > 0 in float32
    assert (net(torch.randn(10, 3)) > 0).all()


def test_deform_net_maps_the_plane_to_the_plane():
    torch.manual_seed(0)
    net = DeformNet(NetConfig(width=16, depth=2))
    assert net(torch.randn(9, 2)).shape == (9, 2)


# --------------------------------------------------------------------------- initialization


def test_siren_init_bounds_and_first_layer_frequency():
    torch.manual_seed(0)
    width = 128
    cfg = NetConfig(width=width, depth=3, init="siren", w0=5.0)
    net = ParamNet(cfg)
    assert net.first_scale == 5.0

    first = net.hidden[0].weight  # (width, 3)
    bound0 = 1.0 / 3
    assert first.abs().max() <= bound0
    assert first.abs().max() > 0.9 * bound0  # the range is used, not a tighter one

    bound = math.sqrt(6.0 / width)
    for layer in list(net.hidden[1:]) + [net.out]:
        assert layer.weight.abs().max() <= bound
        assert layer.weight.abs().max() > 0.9 * bound
    assert torch.equal(net.out.bias, torch.zeros_like(net.out.bias))

    x = torch.randn(11, 3)
    torch.testing.assert_close(net(x), _reference_forward(net, x, first_scale=5.0))


def test_default_init_uses_plain_sine_and_pytorch_init():
    torch.manual_seed(0)
    net = ParamNet(NetConfig(width=128, depth=3, init="default", w0=5.0))
    assert net.first_scale == 1.0  # w0 is a SIREN parameter; "default" ignores it

    # PyTorch's Linear init: U(-1/sqrt(in), 1/sqrt(in)), wider than SIREN's 1/in.
    first = net.hidden[0].weight
    assert first.abs().max() <= 1.0 / math.sqrt(3)
    assert first.abs().max() > 1.2 / 3
    hidden = net.hidden[1].weight
    assert hidden.abs().max() <= 1.0 / math.sqrt(128)

    x = torch.randn(11, 3)
    torch.testing.assert_close(net(x), _reference_forward(net, x, first_scale=1.0))


# NetConfig's validation is tested with the other configs in test_config.py.


# --------------------------------------------------------------------------- gradients


@pytest.mark.parametrize(
    "make, in_dim",
    [
        (lambda c: ParamNet(c), 3),
        (lambda c: LambdaInvNet(c), 3),
        (lambda c: DeformNet(c), 2),
    ],
    ids=["param", "lambda_inv", "deform"],
)
@pytest.mark.parametrize("init", ["siren", "default"])
def test_forward_is_differentiable_in_the_input(make, in_dim, init):
    torch.manual_seed(0)
    net = make(NetConfig(width=6, depth=2, init=init)).double()
    x = torch.randn(5, in_dim, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(net, (x,))


def test_forward_is_differentiable_in_the_weights():
    torch.manual_seed(0)
    net = ParamNet(NetConfig(width=5, depth=2)).double()
    names = [n for n, _ in net.named_parameters()]
    params = tuple(p.detach().clone().requires_grad_(True) for p in net.parameters())
    x = torch.randn(4, 3, dtype=torch.float64)

    def f(*ps):
        return functional_call(net, dict(zip(names, ps)), (x,))

    assert torch.autograd.gradcheck(f, params)


# --------------------------------------------------------------------------- plane term


def test_param_net_with_a_plane_starts_as_that_projection_and_trains_both_parts():
    torch.manual_seed(0)
    plane = torch.tensor([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    net = ParamNet(NetConfig(width=16, depth=2), plane=plane)
    x = torch.randn(50, 3)
    torch.testing.assert_close(net(x), x @ plane.T)
    net(x).pow(2).sum().backward()
    assert net.plane.weight.grad.abs().sum() > 0
    assert net.out.weight.grad.abs().sum() > 0  # the sine part leaves zero at once


def test_param_net_plane_start_is_shifted_by_the_offset():
    """The offset (a domain's centroid) moves the starting projection there."""
    torch.manual_seed(0)
    plane = torch.tensor([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    offset = torch.tensor([3.0, -2.0])
    net = ParamNet(NetConfig(width=16, depth=2), plane=plane, offset=offset)
    x = torch.randn(50, 3)
    torch.testing.assert_close(net(x), x @ plane.T + offset)


def test_param_net_rejects_a_plane_of_the_wrong_shape():
    with pytest.raises(ValueError, match=r"expected shape \(2, 3\), got \(3, 3\)"):
        ParamNet(NetConfig(width=4, depth=1), plane=torch.eye(3))
