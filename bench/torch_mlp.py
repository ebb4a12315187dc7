#!/usr/bin/env python3
"""The reference NeRF MLP's training step in PyTorch, timed one step at a time on request.

nova-bench mlp starts this script as a child and alternates with its own steps, so both see the
same machine state: it writes one line per step it is asked for on stdin ("step\n") with the
seconds that step took, and exits on end of input. The network is nova-bench's: INPUTS inputs,
DEPTH x WIDTH ReLU layers, the input concatenated again after layer index SKIP, 4 linear
outputs, an MSE loss against a constant target, and one Adam update per step (PyTorch's Adam,
the formulation nova's optimiser follows).

usage: torch_mlp.py BATCH [--threads N] [--inputs 63] [--width 256] [--depth 8] [--skip 4] [--forward-only]
Prints "ready torch VERSION threads N" once the first (warm-up) step is done, or
"unavailable: REASON" and exits 3 where torch cannot be imported.
"""
import argparse
import sys
import time


def main():
    p = argparse.ArgumentParser()
    p.add_argument("batch", type=int)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--inputs", type=int, default=63)
    p.add_argument("--width", type=int, default=256)
    p.add_argument("--depth", type=int, default=8)
    p.add_argument("--skip", type=int, default=4)
    p.add_argument("--forward-only", action="store_true")
    a = p.parse_args()
    try:
        import torch
    except ImportError as e:
        print(f"unavailable: {e}", flush=True)
        return 3
    torch.set_num_threads(a.threads)
    torch.manual_seed(0)

    class Mlp(torch.nn.Module):
        def __init__(self):
            super().__init__()
            layers, k = [], a.inputs
            for i in range(a.depth):
                layers.append(torch.nn.Linear(k, a.width))
                k = a.inputs + a.width if i == a.skip else a.width
            self.hidden = torch.nn.ModuleList(layers)
            self.out = torch.nn.Linear(k, 4)

        def forward(self, x):
            h = x
            for i, layer in enumerate(self.hidden):
                h = torch.relu(layer(h))
                if i == a.skip:
                    h = torch.cat([x, h], dim=-1)
            return self.out(h)

    net = Mlp()
    opt = torch.optim.Adam(net.parameters(), lr=5e-4)
    x = torch.full((a.batch, a.inputs), 0.1)
    target = torch.full((a.batch, 4), 0.5)

    def step():
        if a.forward_only:
            with torch.no_grad():
                net(x)
            return
        opt.zero_grad(set_to_none=True)
        loss = torch.nn.functional.mse_loss(net(x), target)
        loss.backward()
        opt.step()

    step()
    print(f"ready torch {torch.__version__} threads {torch.get_num_threads()}", flush=True)
    for line in sys.stdin:
        if line.strip() != "step":
            continue
        t0 = time.perf_counter()
        step()
        print(f"{time.perf_counter() - t0:.9f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
