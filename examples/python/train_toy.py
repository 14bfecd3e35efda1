"""From a video to a dataset to a trained toy model, in PyTorch.

    python examples/python/train_toy.py                    # bundled sample data
    python examples/python/train_toy.py --video me.mp4 --out out/toy

1. extract the iris trajectory of a talking-head video (eyereplay.extract);
2. generate a labeled dataset: conversation sessions from that video's eye
   movements, reading sessions from the bundled reading fixations
   (eyereplay.generate: sessions, MP4 videos, labels, report);
3. train a small 1-D CNN on 2-s trajectory windows of some sessions and
   report its accuracy on windows of the sessions it never saw.

A toy: few sessions and a tiny model, minutes on a laptop CPU. It shows
the moving parts, not a detector's accuracy.
Needs: pip install eyereplay-*.whl torch
"""

import argparse
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.utils.data import DataLoader, Subset

import eyereplay

here = Path(__file__).resolve().parents[2]
data = here / ".cache" / "data"

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--video", type=Path, default=data / "franck.mp4", help="a talking-head video")
ap.add_argument("--reading", type=Path, default=data / "onestop_fixations.csv",
                help="reading fixations (OneStop layout)")
ap.add_argument("--out", type=Path, default=Path("out/toy"), help="dataset folder")
ap.add_argument("--sessions", type=int, default=8, help="sessions per class")
ap.add_argument("--epochs", type=int, default=15)
args = ap.parse_args()

# 1. The video's eye movements, frame by frame.
iris = eyereplay.extract(args.video, out=args.out / "iris.csv")
ok = iris["valid"] == 1
print(f"{args.video.name}: {len(iris)} frames, iris found in {ok.mean():.0%}, "
      f"nx spread {np.nanstd(iris['nx'][ok]):.3f}")

# 2. A labeled dataset; the config is a dict of the TOML tables.
config = {
    "session_frames": 250,  # 10 s at 25 fps
    "seed": 1,
    "render": {"width": 640, "height": 360, "natural_blinks": True},
    "classes": {
        "reading": {"sessions": args.sessions, "sources": [{
            "format": "fixations", "path": str(args.reading),
            "group_columns": ["participant_id", "TRIAL_INDEX"],
            "amplitude_column": "NEXT_SAC_AMPLITUDE", "screen_px": [2560, 1440]}]},
        "conversation": {"sessions": args.sessions, "sources": [
            {"format": "extract", "path": str(args.out / "iris.csv")}]},
    },
}
summary = eyereplay.generate(config, args.out)
print(f"rendered {summary['rendered']} sessions; report: {summary['report']}")

# 3. Train on trajectory windows, test on sessions held out.
ds = eyereplay.load_dataset(args.out)
windows = ds.as_torch(window=50, stride=25)
per_session = len(windows) // len(ds)
test_sessions = {i for i, s in enumerate(ds) if int(s.file[-8:-4]) % 4 == 0}
train_idx = [i for i in range(len(windows)) if i // per_session not in test_sessions]
test_idx = [i for i in range(len(windows)) if i // per_session in test_sessions]

torch.manual_seed(0)
model = nn.Sequential(
    nn.Conv1d(2, 16, 5, padding=2), nn.ReLU(),
    nn.Conv1d(16, 16, 5, padding=2), nn.ReLU(),
    nn.AdaptiveAvgPool1d(1), nn.Flatten(), nn.Linear(16, 2),
)
opt = torch.optim.Adam(model.parameters(), lr=3e-3)


def batches(idx, shuffle):
    return DataLoader(Subset(windows, idx), batch_size=32, shuffle=shuffle)


def velocity(x):  # (batch, window, 2) canvas positions -> (batch, 2, window) steps
    v = torch.diff(x, dim=1, prepend=x[:, :1])
    return (v * 100).transpose(1, 2)


for epoch in range(args.epochs):
    model.train()
    for x, y in batches(train_idx, True):
        loss = nn.functional.cross_entropy(model(velocity(x)), y)
        opt.zero_grad()
        loss.backward()
        opt.step()

model.eval()
correct = total = 0
with torch.no_grad():
    for x, y in batches(test_idx, False):
        correct += (model(velocity(x)).argmax(1) == y).sum().item()
        total += len(y)
print(f"held-out windows: {correct}/{total} correct ({correct / max(total, 1):.0%}); "
      f"chance is 50 %")
