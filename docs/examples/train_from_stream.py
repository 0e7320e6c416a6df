"""Train a tiny network on reefgen pairs streamed from the generator (docs/PYTHON.md).

    PYTHONPATH=build/python python3 docs/examples/train_from_stream.py [STEPS]
"""
import sys

import torch
from torch.utils.data import DataLoader

import reefgen
from reefgen.torch import PairStream

steps = int(sys.argv[1]) if len(sys.argv) > 1 else 20
config = {"size_px": 64}  # the dataset recipe (docs/DATASET.md), here at 64²
# Label map -> height, heights scaled from reefgen.HEIGHT_RANGE_M ([-100, 560] m) to [-1, 1];
# the training split only, shuffled, dealt to the workers in whole batches.
stream = PairStream(config, seed=1, split="train", shuffle=True, batch_size=4,
                    height_range_m=reefgen.HEIGHT_RANGE_M)
loader = DataLoader(stream, batch_size=4, num_workers=2)
torch.manual_seed(0)  # the network's initial weights
net = torch.nn.Sequential(torch.nn.Conv2d(3, 16, 3, padding=1), torch.nn.ReLU(),
                          torch.nn.Conv2d(16, 1, 3, padding=1), torch.nn.Tanh())
opt = torch.optim.Adam(net.parameters(), lr=2e-3)
for step, (label, height) in enumerate(loader, 1):  # {4,3,64,64}, {4,1,64,64}
    loss = torch.nn.functional.l1_loss(net(label), height)
    opt.zero_grad()
    loss.backward()
    opt.step()
    if step == 1 or step % 5 == 0:
        print(f"step {step}: L1 {loss.item():.4f}")
    if step == steps:
        break
