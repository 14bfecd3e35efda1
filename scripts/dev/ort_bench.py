#!/usr/bin/env python3
"""Milliseconds per inference of extraction's networks in whichever
onnxruntime Python package is importable: one thread, no spinning,
every graph optimization, caches disturbed between runs as the pipeline
disturbs them (median of N runs after 20 warm-up runs). To compare
ONNX Runtime versions, unpack each wheel (`pip download --no-deps
onnxruntime==X`, then unzip it into a folder) and run this with that
folder first on PYTHONPATH, alternating (docs/PERFORMANCE.md):

    PYTHONPATH=ort-1.24.4 python3 scripts/dev/ort_bench.py [MODELS_DIR] [N]

Needs numpy. MODELS_DIR defaults to $EYEREPLAY_CACHE/models or .cache/models.
"""
import os
import sys
import time

import numpy as np
import onnxruntime as ort

models = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
    os.environ.get("EYEREPLAY_CACHE", ".cache"), "models")
runs = int(sys.argv[2]) if len(sys.argv) > 2 else 200

so = ort.SessionOptions()
so.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
so.intra_op_num_threads = 1
so.inter_op_num_threads = 1
so.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
so.add_session_config_entry("session.intra_op.allow_spinning", "0")

rng = np.random.default_rng(0)
feeds = {
    "face_landmark_with_attention.onnx": {"input": rng.random((1, 3, 192, 192), dtype=np.float32)},
    "face_landmark_with_attention_eyes.onnx": {
        "left_eye_features": rng.random((1, 32, 16, 16), dtype=np.float32),
        "right_eye_features": rng.random((1, 32, 16, 16), dtype=np.float32),
    },
    # The iris model as the extractor runs it on the CPU: two eyes a run.
    "iris_landmark.onnx": {"input": rng.random((2, 3, 64, 64), dtype=np.float32)},
    "face_landmark.onnx": {"input": rng.random((1, 3, 192, 192), dtype=np.float32)},
}
trash = np.zeros(8_000_000, dtype=np.float32)
line = [f"onnxruntime {ort.__version__}"]
for name, feed in feeds.items():
    path = os.path.join(models, name)
    if not os.path.isfile(path):
        sys.exit(f"error: {path}: missing; run scripts/setup.sh")
    s = ort.InferenceSession(path, so, providers=["CPUExecutionProvider"])
    for _ in range(20):
        s.run(None, feed)
    times = []
    for _ in range(runs):
        trash += 1  # 32 MB touched: the caches as decoding leaves them
        t = time.thread_time()
        s.run(None, feed)
        times.append(time.thread_time() - t)
    line.append(f"{name.removesuffix('.onnx')} {np.median(times) * 1e3:.3f} ms")
print(" | ".join(line))
