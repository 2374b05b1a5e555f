#!/usr/bin/env bash
# Makes models/pose_detection.onnx and models/pose_landmark_full.onnx from BlazePose's TFLite
# files in the PyPI package mediapipe==0.10.14 (later versions ship none). Run once by a
# maintainer; CI and users never run it. Needs Python 3.11 and the package registries; works in
# a throw-away virtual environment under $TMPDIR.
#
#   bash models/convert.sh            # writes the two .onnx files beside this script
#
# The detector stores its weights sparse (DENSIFY ops), which tf2onnx cannot read: densify.py
# folds them into dense constants first, read back through the TFLite interpreter without the
# XNNPACK delegate (with it they come back as zeros). The outputs are checked against the
# TFLite models on a bundled frame (largest difference printed).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
python3 -m venv "$work/venv"
pip="$work/venv/bin/pip"
py="$work/venv/bin/python"
"$pip" install -q "tensorflow-cpu==2.15.1" "tf2onnx==1.17.0" "onnx==1.16.2" \
  "onnxruntime==1.20.1" "numpy==1.26.4" "protobuf==3.20.3" "pillow==11.0.0"
"$pip" download -q --no-deps -d "$work/dl" "mediapipe==0.10.14"
unzip -q -j -o "$work"/dl/mediapipe-0.10.14-*.whl \
  mediapipe/modules/pose_detection/pose_detection.tflite \
  mediapipe/modules/pose_landmark/pose_landmark_full.tflite -d "$work"
echo "sha256 of the TFLite inputs:"
sha256sum "$work/pose_detection.tflite" "$work/pose_landmark_full.tflite"
"$py" "$here/densify.py" "$work/pose_detection.tflite" "$work/pose_detection_dense.tflite"
"$py" -m tf2onnx.convert --tflite "$work/pose_detection_dense.tflite" --opset 13 \
  --output "$here/pose_detection.onnx"
"$py" -m tf2onnx.convert --tflite "$work/pose_landmark_full.tflite" --opset 13 \
  --output "$here/pose_landmark_full.onnx"
"$py" - "$work" "$here" <<'PY'
import sys, numpy as np, tensorflow as tf, onnxruntime as ort
from PIL import Image
work, here = sys.argv[1], sys.argv[2]
img = Image.open(f"{here}/../tests/it/data/pose-frame.png").convert("RGB")
for name, side, lo in [("pose_detection", 224, -1.0), ("pose_landmark_full", 256, 0.0)]:
    x = np.asarray(img.resize((side, side)), np.float32) / 255.0
    x = (x * (1.0 - lo) + lo)[None]
    it = tf.lite.Interpreter(model_path=f"{work}/{name}.tflite",
        experimental_op_resolver_type=tf.lite.experimental.OpResolverType.BUILTIN_WITHOUT_DEFAULT_DELEGATES)
    it.allocate_tensors(); it.set_tensor(it.get_input_details()[0]["index"], x); it.invoke()
    a = [it.get_tensor(d["index"]) for d in it.get_output_details()]
    s = ort.InferenceSession(f"{here}/{name}.onnx", providers=["CPUExecutionProvider"])
    b = s.run(None, {s.get_inputs()[0].name: x})
    print(name, "largest difference per output:",
          [float(np.max(np.abs(p - q.reshape(p.shape)))) for p, q in zip(a, b)])
PY
sha256sum "$here"/*.onnx
