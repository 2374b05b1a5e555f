# densify.py — used by convert.sh (see NOTICE).
"""Rewrite a TFLite model whose weights are stored sparse (DENSIFY ops) into one with dense
constant weights, so tf2onnx can read it. The dense values are read back through the TFLite
interpreter without the XNNPACK delegate (with it they come back as zeros)."""
import sys
import numpy as np
import tensorflow as tf
from tensorflow.lite.python import schema_py_generated as schema
from tensorflow.lite.tools import flatbuffer_utils as fbu

src, dst = sys.argv[1], sys.argv[2]
interp = tf.lite.Interpreter(
    model_path=src,
    experimental_op_resolver_type=tf.lite.experimental.OpResolverType.BUILTIN_WITHOUT_DEFAULT_DELEGATES,
    experimental_preserve_all_tensors=True,
)
interp.allocate_tensors()
for d in interp.get_input_details():
    interp.set_tensor(d["index"], np.zeros(d["shape"], d["dtype"]))
interp.invoke()

model = fbu.read_model(src)
densify_codes = {
    i for i, c in enumerate(model.operatorCodes)
    if max(c.builtinCode, c.deprecatedBuiltinCode) == schema.BuiltinOperator.DENSIFY
}
assert len(model.subgraphs) == 1
sg = model.subgraphs[0]
kept, n = [], 0
for op in sg.operators:
    if op.opcodeIndex not in densify_codes:
        kept.append(op)
        continue
    (inp,), (out,) = op.inputs, op.outputs
    dense = interp.get_tensor(out)
    assert np.any(dense != 0), "dense weights came back as zeros"
    buf = schema.BufferT()
    buf.data = np.frombuffer(dense.tobytes(), np.uint8)
    model.buffers.append(buf)
    sg.tensors[out].buffer = len(model.buffers) - 1
    sg.tensors[inp].sparsity = None
    n += 1
sg.operators = kept
# Drop the sparse tensors no operator reads any more, renumbering the rest.
used = sorted({t for op in sg.operators for t in list(op.inputs) + list(op.outputs) if t >= 0}
              | set(sg.inputs) | set(sg.outputs))
remap = {old: new for new, old in enumerate(used)}
sg.tensors = [sg.tensors[i] for i in used]
for op in sg.operators:
    op.inputs = [remap[t] if t >= 0 else t for t in op.inputs]
    op.outputs = [remap[t] for t in op.outputs]
sg.inputs = [remap[t] for t in sg.inputs]
sg.outputs = [remap[t] for t in sg.outputs]
fbu.write_model(model, dst)
print(f"{n} DENSIFY ops folded into constants")
