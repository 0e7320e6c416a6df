#!/usr/bin/env python3
"""Reference pix2pix networks for reefgen's equivalence test.

Builds the generator and discriminator exactly as the original
pytorch-CycleGAN-and-pix2pix code does (recursive UnetSkipConnectionBlock with
in-place ReLUs, NLayerDiscriminator), written here from its description, and
writes to OUT/reference.{json,bin}:
  - every parameter and buffer, under reefgen's C++ names (model/src/networks.cpp);
  - a fixed input x (label) and y (height);
  - G and D outputs in train mode (batch statistics, dropout off) and in eval
    mode (running statistics, updated by the train-mode pass before);
  - the four losses of two pix2pix optimisation steps from the saved weights
    (Adam 2e-4, betas (0.5, 0.999), BCE-with-logits GAN loss, 100*L1, D loss
    halved, D frozen for the G step), and G's eval output after them.
Needs Debian's python3-torch (1.13). Usage:
  python3 pix2pix_ref.py --out DIR [--ngf 64] [--ndf 64] [--size 256] [--depth 8]
"""
import argparse
import copy
import json
import os

import numpy as np
import torch
from torch import nn


class UnetSkipConnectionBlock(nn.Module):
    def __init__(self, outer_nc, inner_nc, input_nc=None, submodule=None,
                 outermost=False, innermost=False, use_dropout=False):
        super().__init__()
        self.outermost = outermost
        if input_nc is None:
            input_nc = outer_nc
        use_bias = False  # BatchNorm
        downconv = nn.Conv2d(input_nc, inner_nc, 4, 2, 1, bias=use_bias)
        downrelu = nn.LeakyReLU(0.2, True)
        downnorm = nn.BatchNorm2d(inner_nc)
        uprelu = nn.ReLU(True)
        upnorm = nn.BatchNorm2d(outer_nc)
        keep_downnorm = keep_upnorm = None
        if outermost:
            upconv = nn.ConvTranspose2d(inner_nc * 2, outer_nc, 4, 2, 1)
            model = [downconv, submodule, uprelu, upconv, nn.Tanh()]
        elif innermost:
            upconv = nn.ConvTranspose2d(inner_nc, outer_nc, 4, 2, 1, bias=use_bias)
            model = [downrelu, downconv, uprelu, upconv, upnorm]
            keep_upnorm = upnorm
        else:
            upconv = nn.ConvTranspose2d(inner_nc * 2, outer_nc, 4, 2, 1, bias=use_bias)
            model = [downrelu, downconv, downnorm, submodule, uprelu, upconv, upnorm]
            if use_dropout:
                model += [nn.Dropout(0.5)]
            keep_downnorm, keep_upnorm = downnorm, upnorm
        # A plain tuple: references for the name map, not registered as
        # submodules, so the state_dict is the original code's.
        self.parts = (downconv, keep_downnorm, upconv, keep_upnorm, submodule)
        self.model = nn.Sequential(*model)

    def forward(self, x):
        if self.outermost:
            return self.model(x)
        return torch.cat([x, self.model(x)], 1)


class UnetGenerator(nn.Module):
    def __init__(self, input_nc, output_nc, num_downs, ngf):
        super().__init__()
        block = UnetSkipConnectionBlock(ngf * 8, ngf * 8, innermost=True)
        for _ in range(num_downs - 5):
            block = UnetSkipConnectionBlock(ngf * 8, ngf * 8, submodule=block, use_dropout=True)
        block = UnetSkipConnectionBlock(ngf * 4, ngf * 8, submodule=block)
        block = UnetSkipConnectionBlock(ngf * 2, ngf * 4, submodule=block)
        block = UnetSkipConnectionBlock(ngf, ngf * 2, submodule=block)
        self.model = UnetSkipConnectionBlock(output_nc, ngf, input_nc=input_nc, submodule=block, outermost=True)

    def forward(self, x):
        return self.model(x)

    def levels(self):
        b = self.model
        while b is not None:
            yield b
            b = b.parts[4]


class NLayerDiscriminator(nn.Module):
    def __init__(self, input_nc, ndf=64, n_layers=3):
        super().__init__()
        seq = [nn.Conv2d(input_nc, ndf, 4, 2, 1), nn.LeakyReLU(0.2, True)]
        mult = 1
        for n in range(1, n_layers):
            prev, mult = mult, min(2 ** n, 8)
            seq += [nn.Conv2d(ndf * prev, ndf * mult, 4, 2, 1, bias=False), nn.BatchNorm2d(ndf * mult),
                    nn.LeakyReLU(0.2, True)]
        prev, mult = mult, min(2 ** n_layers, 8)
        seq += [nn.Conv2d(ndf * prev, ndf * mult, 4, 1, 1, bias=False), nn.BatchNorm2d(ndf * mult),
                nn.LeakyReLU(0.2, True)]
        seq += [nn.Conv2d(ndf * mult, 1, 4, 1, 1)]
        self.model = nn.Sequential(*seq)

    def forward(self, x):
        return self.model(x)


def init_weights(net, gain=0.02):
    for m in net.modules():
        if isinstance(m, (nn.Conv2d, nn.ConvTranspose2d)):
            nn.init.normal_(m.weight, 0.0, gain)
            if m.bias is not None:
                nn.init.constant_(m.bias, 0.0)
        elif isinstance(m, nn.BatchNorm2d):
            nn.init.normal_(m.weight, 1.0, gain)
            nn.init.constant_(m.bias, 0.0)


def state_of_module(prefix, m, out):
    for name, t in list(m.named_parameters(recurse=False)) + list(m.named_buffers(recurse=False)):
        out[prefix + name] = t.detach().clone()


def g_state(G):
    """G's parameters and buffers under the C++ names levels.K.{down_conv,down_norm.bn,up_conv,up_norm.bn}."""
    out = {}
    for k, b in enumerate(G.levels()):
        downconv, downnorm, upconv, upnorm, _ = b.parts
        state_of_module(f"levels.{k}.down_conv.", downconv, out)
        if downnorm is not None:
            state_of_module(f"levels.{k}.down_norm.bn.", downnorm, out)
        state_of_module(f"levels.{k}.up_conv.", upconv, out)
        if upnorm is not None:
            state_of_module(f"levels.{k}.up_norm.bn.", upnorm, out)
    assert len(out) == len(G.state_dict()), "name map misses a tensor"
    return out


def d_state(D):
    out = {}
    for i, m in enumerate(D.model):
        state_of_module(f"net.{i}." + ("bn." if isinstance(m, nn.BatchNorm2d) else ""), m, out)
    assert len(out) == len(D.state_dict()), "name map misses a tensor"
    return out


def dropout_off(net):
    for m in net.modules():
        if isinstance(m, nn.Dropout):
            m.eval()


def train_steps(G, D, x, y, steps):
    """pix2pix's optimize_parameters, `steps` times; returns the losses of each step."""
    opt_g = torch.optim.Adam(G.parameters(), lr=2e-4, betas=(0.5, 0.999))
    opt_d = torch.optim.Adam(D.parameters(), lr=2e-4, betas=(0.5, 0.999))
    bce, l1 = nn.BCEWithLogitsLoss(), nn.L1Loss()
    G.train(); D.train(); dropout_off(G)
    losses = []
    for _ in range(steps):
        fake = G(x)
        for p in D.parameters():
            p.requires_grad_(True)
        opt_d.zero_grad()
        pred_fake = D(torch.cat([x, fake], 1).detach())
        d_fake = bce(pred_fake, torch.zeros_like(pred_fake))
        pred_real = D(torch.cat([x, y], 1))
        d_real = bce(pred_real, torch.ones_like(pred_real))
        ((d_fake + d_real) * 0.5).backward()
        opt_d.step()
        for p in D.parameters():
            p.requires_grad_(False)
        opt_g.zero_grad()
        pred = D(torch.cat([x, fake], 1))
        g_gan = bce(pred, torch.ones_like(pred))
        g_l1 = l1(fake, y) * 100.0
        (g_gan + g_l1).backward()
        opt_g.step()
        losses.append([g_gan.item(), g_l1.item(), d_real.item(), d_fake.item()])
    return losses


def write(out_dir, tensors, meta):
    os.makedirs(out_dir, exist_ok=True)
    index, offset = [], 0
    tmp_bin = os.path.join(out_dir, "reference.bin.tmp")
    with open(tmp_bin, "wb") as f:
        for name, t in tensors.items():
            a = t.detach().cpu().contiguous().numpy()
            dtype = {np.float32: "f32", np.int64: "i64"}[a.dtype.type]
            data = a.astype("<f4" if dtype == "f32" else "<i8").tobytes()
            index.append({"name": name, "dtype": dtype, "shape": list(a.shape), "offset": offset})
            f.write(data)
            offset += len(data)
    os.replace(tmp_bin, os.path.join(out_dir, "reference.bin"))
    tmp_json = os.path.join(out_dir, "reference.json.tmp")
    with open(tmp_json, "w") as f:
        json.dump({"meta": meta, "tensors": index}, f, indent=1)
    os.replace(tmp_json, os.path.join(out_dir, "reference.json"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--ngf", type=int, default=64)
    ap.add_argument("--ndf", type=int, default=64)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--depth", type=int, default=8)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    G = UnetGenerator(3, 1, a.depth, a.ngf)
    D = NLayerDiscriminator(4, a.ndf, 3)
    init_weights(G)
    init_weights(D)
    G0, D0 = copy.deepcopy(G), copy.deepcopy(D)
    x = torch.rand(1, 3, a.size, a.size) * 2 - 1
    y = torch.rand(1, 1, a.size, a.size) * 2 - 1

    t = {("G." + k): v for k, v in g_state(G).items()}
    t.update({("D." + k): v for k, v in d_state(D).items()})
    t["x"], t["y"] = x, y
    with torch.no_grad():
        G.train(); dropout_off(G)
        t["out.G.train"] = G(x)
        G.eval()
        t["out.G.eval"] = G(x)
        xy = torch.cat([x, y], 1)
        D.train()
        t["out.D.train"] = D(xy)
        D.eval()
        t["out.D.eval"] = D(xy)
    losses = train_steps(G0, D0, x, y, 2)
    with torch.no_grad():
        G0.eval()
        t["out.G.after_steps"] = G0(x)
    meta = {"ngf": a.ngf, "ndf": a.ndf, "size": a.size, "depth": a.depth, "seed": a.seed,
            "torch": torch.__version__,
            "params_G": sum(p.numel() for p in G.parameters()),
            "params_D": sum(p.numel() for p in D.parameters()),
            "losses": losses, "loss_names": ["G_GAN", "G_L1", "D_real", "D_fake"]}
    write(a.out, t, meta)
    print(json.dumps({k: meta[k] for k in ("params_G", "params_D", "losses")}))


if __name__ == "__main__":
    main()
