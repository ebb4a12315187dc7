#!/usr/bin/env python3
"""The reference NeRF MLP's training step in PyTorch, timed one step at a time on request.

nova-bench mlp starts this script as a child and alternates with its own steps, so both see the
same machine state: it writes one line per step it is asked for on stdin ("step\n") with the
seconds that step took, and exits on end of input. The network is nova-bench's: INPUTS inputs,
DEPTH x WIDTH ReLU layers, the input concatenated again after layer index SKIP, 4 linear
outputs, an MSE loss against a constant target, and one Adam update per step (PyTorch's Adam,
the formulation nova's optimiser follows).

usage: torch_mlp.py BATCH [--threads N] [--device cpu|cuda] [--inputs 63] [--width 256] [--depth 8] [--skip 4]
                    [--forward-only]
On a CUDA device each timed step ends with torch.cuda.synchronize(), as nova's ends with
clFinish: both times cover the whole step's device work.
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
    p.add_argument("--device", default="cpu")
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
    if a.device != "cpu" and not (a.device.startswith("cuda") and torch.cuda.is_available()):
        print(f"unavailable: torch {torch.__version__} has no device {a.device}", flush=True)
        return 3
    dev = torch.device(a.device)
    # float32 as nova computes: no TF32 matrix units (PyTorch's default for matmul, said outright).
    torch.backends.cuda.matmul.allow_tf32 = False
    torch.backends.cudnn.allow_tf32 = False

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

    net = Mlp().to(dev)
    opt = torch.optim.Adam(net.parameters(), lr=5e-4)
    x = torch.full((a.batch, a.inputs), 0.1, device=dev)
    target = torch.full((a.batch, 4), 0.5, device=dev)
    sync = torch.cuda.synchronize if dev.type == "cuda" else (lambda: None)

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
    sync()
    where = torch.cuda.get_device_name(dev) if dev.type == "cuda" else f"threads {torch.get_num_threads()}"
    print(f"ready torch {torch.__version__} {where}", flush=True)
    for line in sys.stdin:
        if line.strip() != "step":
            continue
        sync()
        t0 = time.perf_counter()
        step()
        sync()
        print(f"{time.perf_counter() - t0:.9f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
