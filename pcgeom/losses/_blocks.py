"""Recomputation of a block during backward, for the losses' ``"chunked"`` backends."""

from __future__ import annotations

from collections.abc import Callable

import torch

__all__ = ["recomputed"]


class _Recomputed(torch.autograd.Function):
    """``fn(*inputs)`` computed without keeping its graph, and rebuilt during backward.

    A checkpoint segment in a dozen lines. ``torch.utils.checkpoint`` does the same, but its
    non-reentrant form imports ``torch._dynamo`` on first use (seconds) and costs about 10 ms
    per call on a CPU, which a loop over hundreds of blocks would pay every step.
    """

    @staticmethod
    def forward(ctx, fn, *inputs):
        ctx.fn = fn
        ctx.save_for_backward(*inputs)
        return fn(*inputs)  # a Function's forward runs without building a graph

    @staticmethod
    def backward(ctx, *grad_outputs):
        needs = ctx.needs_input_grad[1:]
        inputs = [x.detach().requires_grad_(need) for x, need in zip(ctx.saved_tensors, needs)]
        with torch.enable_grad():
            outputs = ctx.fn(*inputs)
        outputs = outputs if isinstance(outputs, tuple) else (outputs,)
        used = [(o, g) for o, g in zip(outputs, grad_outputs) if o.requires_grad]
        wanted = [x for x in inputs if x.requires_grad]
        grads = iter(torch.autograd.grad([o for o, _ in used], wanted, [g for _, g in used],
                                         allow_unused=True))
        return (None, *(next(grads) if x.requires_grad else None for x in inputs))


def recomputed(fn: Callable[..., torch.Tensor | tuple[torch.Tensor, ...]],
               *inputs: torch.Tensor):
    """``fn(*inputs)`` whose intermediates are freed after forward and recomputed in backward.

    ``fn`` must be a pure function of the tensors ``inputs`` (other values it needs are bound
    in a closure). Memory of a loop over blocks is then that of one block in both directions;
    backward costs one extra forward pass of each block. Double backward is not supported.
    """
    return _Recomputed.apply(fn, *inputs)
