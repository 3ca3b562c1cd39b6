#!/usr/bin/env python3
"""Convert MediaPipe's face landmark model (TFLite, Apache-2.0) to ONNX for facewire.

facewire reads the ONNX file and runs its operators itself (core/src/fit/automatic/conv_net.rs). The model is the
`face_landmark.tflite` that MediaPipe's PyPI wheel 0.10.14 carries
(mediapipe/modules/face_landmark/): 468 face-mesh points from a 192 x 192 RGB crop.
It uses seven TFLite operators (CONV_2D, DEPTHWISE_CONV_2D, PRELU, ADD, MAX_POOL_2D, PAD,
and DEQUANTIZE of its float16 weights); this script maps each to ONNX by hand, folds the
float16 weights into float32 constants, and checks the ONNX model against the TFLite one on
random and real crops with onnx's reference evaluator (max abs difference printed).

    python3 -m venv /tmp/fl && . /tmp/fl/bin/activate
    pip install tflite==2.18.0 onnx numpy
    pip download mediapipe==0.10.14 --no-deps -d /tmp/fl
    python3 tools/face_landmarks/convert.py /tmp/fl/mediapipe-0.10.14-*.whl data/models/face_landmark.onnx

Input `image`: float32 [1, 3, 192, 192], RGB in [0, 1], rows top down. Outputs
`landmarks`: [1, 1404] (468 x (x, y, z) in crop pixels, z relative, same scale as x) and
`face_flag`: [1, 1] (a logit: the crop holds a face).
"""
import sys
import zipfile

import numpy as np
import onnx
import tflite
from onnx import TensorProto, helper, numpy_helper

MEMBER = "mediapipe/modules/face_landmark/face_landmark.tflite"

OPS = {v: k for k, v in tflite.BuiltinOperator.__dict__.items() if not k.startswith("_")}


def op_name(model, op):
    code = model.OperatorCodes(op.OpcodeIndex())
    return OPS[max(code.BuiltinCode(), code.DeprecatedBuiltinCode())]


def same_pads(size, kernel, stride, dilation=1):
    out = -(-size // stride)
    total = max((out - 1) * stride + (kernel - 1) * dilation + 1 - size, 0)
    return total // 2, total - total // 2


def convert(tflite_bytes):
    model = tflite.Model.GetRootAsModel(tflite_bytes, 0)
    graph = model.Subgraphs(0)

    def tensor(i):
        return graph.Tensors(i)

    def shape(i):
        return list(tensor(i).ShapeAsNumpy())

    def constant(i):
        t = tensor(i)
        data = model.Buffers(t.Buffer()).DataAsNumpy()
        if isinstance(data, int) or data.size == 0:
            return None
        dtype = {tflite.TensorType.FLOAT32: np.float32, tflite.TensorType.FLOAT16: np.float16,
                 tflite.TensorType.INT32: np.int32}[t.Type()]
        return np.frombuffer(data.tobytes(), dtype=dtype).reshape(shape(i))

    constants = {}  # tensor index -> float32 / int32 array
    for i in range(graph.TensorsLength()):
        c = constant(i)
        if c is not None:
            constants[i] = c.astype(np.float32) if c.dtype == np.float16 else c

    names = {}

    def name(i):
        return names.get(i, f"t{i}")

    nodes, inits = [], []

    def init(array, label):
        inits.append(numpy_helper.from_array(np.ascontiguousarray(array), label))
        return label

    def activation(out, fused, label):
        if fused == 0:
            return out
        if fused != 1:
            raise SystemExit(f"fused activation {fused} not handled")
        nodes.append(helper.make_node("Relu", [out + "_pre"], [out], name=label + "_relu"))
        return out + "_pre"

    for k in range(graph.OperatorsLength()):
        op = graph.Operators(k)
        kind = op_name(model, op)
        ins = list(op.InputsAsNumpy())
        out = op.Outputs(0)
        label = f"{kind.lower()}_{k}"
        if kind == "DEQUANTIZE":
            constants[out] = constants[ins[0]].astype(np.float32)
            continue
        if kind in ("CONV_2D", "DEPTHWISE_CONV_2D"):
            opts_type = tflite.Conv2DOptions if kind == "CONV_2D" else tflite.DepthwiseConv2DOptions
            opts = opts_type()
            opts.Init(op.BuiltinOptions().Bytes, op.BuiltinOptions().Pos)
            weight = constants[ins[1]]
            _, in_h, in_w, in_c = shape(ins[0])
            if kind == "CONV_2D":
                w = weight.transpose(0, 3, 1, 2)  # OHWI -> OIHW
                group = 1
            else:
                w = weight.transpose(3, 0, 1, 2)  # 1HW(C*m) -> (C*m)1HW
                group = in_c
            kh, kw = w.shape[2], w.shape[3]
            sh, sw = opts.StrideH(), opts.StrideW()
            dh, dw = opts.DilationHFactor(), opts.DilationWFactor()
            if opts.Padding() == tflite.Padding.SAME:
                top, bottom = same_pads(in_h, kh, sh, dh)
                left, right = same_pads(in_w, kw, sw, dw)
            else:
                top = bottom = left = right = 0
            inputs = [name(ins[0]), init(w, label + "_w")]
            if len(ins) > 2 and ins[2] >= 0:
                inputs.append(init(constants[ins[2]], label + "_b"))
            target = activation(name(out), opts.FusedActivationFunction(), label)
            nodes.append(helper.make_node(
                "Conv", inputs, [target], name=label, group=group, kernel_shape=[kh, kw],
                strides=[sh, sw], dilations=[dh, dw], pads=[top, left, bottom, right]))
        elif kind == "PRELU":
            alpha = constants[ins[1]].reshape(-1)
            slope = init(alpha.reshape(-1, 1, 1), label + "_slope")
            nodes.append(helper.make_node("PRelu", [name(ins[0]), slope], [name(out)], name=label))
        elif kind == "ADD":
            opts = tflite.AddOptions()
            opts.Init(op.BuiltinOptions().Bytes, op.BuiltinOptions().Pos)
            target = activation(name(out), opts.FusedActivationFunction(), label)
            nodes.append(helper.make_node("Add", [name(ins[0]), name(ins[1])], [target], name=label))
        elif kind == "MAX_POOL_2D":
            opts = tflite.Pool2DOptions()
            opts.Init(op.BuiltinOptions().Bytes, op.BuiltinOptions().Pos)
            _, in_h, in_w, _ = shape(ins[0])
            kh, kw = opts.FilterHeight(), opts.FilterWidth()
            sh, sw = opts.StrideH(), opts.StrideW()
            if opts.Padding() == tflite.Padding.SAME:
                top, bottom = same_pads(in_h, kh, sh)
                left, right = same_pads(in_w, kw, sw)
            else:
                top = bottom = left = right = 0
            nodes.append(helper.make_node(
                "MaxPool", [name(ins[0])], [name(out)], name=label, kernel_shape=[kh, kw],
                strides=[sh, sw], pads=[top, left, bottom, right]))
        elif kind == "PAD":
            pads = constants[ins[1]].astype(np.int64)  # [[n0,n1],[h0,h1],[w0,w1],[c0,c1]] NHWC
            nchw = pads[[0, 3, 1, 2]]
            onnx_pads = np.concatenate([nchw[:, 0], nchw[:, 1]])
            nodes.append(helper.make_node(
                "Pad", [name(ins[0]), init(onnx_pads, label + "_pads")], [name(out)], name=label))
        else:
            raise SystemExit(f"operator {kind} not handled")

    graph_in = graph.Inputs(0)
    names[graph_in] = "image"
    # The graph's input was named before the nodes that read it were made: rename in place.
    for node in nodes:
        for j, value in enumerate(node.input):
            if value == f"t{graph_in}":
                node.input[j] = "image"
    outputs = {}
    for j in range(graph.OutputsLength()):
        o = graph.Outputs(j)
        outputs[tensor(o).Name().decode()] = f"t{o}"
    flat = {"conv2d_21": ("landmarks", 1404), "conv2d_31": ("face_flag", 1)}
    for tfl_name, (label, size) in flat.items():
        nodes.append(helper.make_node(
            "Reshape", [outputs[tfl_name], init(np.array([1, size], np.int64), label + "_shape")],
            [label], name=label + "_reshape"))
    g = helper.make_graph(
        nodes, "face_landmark",
        [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, 192, 192])],
        [helper.make_tensor_value_info("landmarks", TensorProto.FLOAT, [1, 1404]),
         helper.make_tensor_value_info("face_flag", TensorProto.FLOAT, [1, 1])],
        inits)
    m = helper.make_model(g, opset_imports=[helper.make_opsetid("", 13)],
                          producer_name="facewire tools/face_landmarks/convert.py")
    m.doc_string = ("MediaPipe face_landmark.tflite (mediapipe 0.10.14 wheel), Apache-2.0, "
                    "converted to ONNX; see data/models/LICENSES.md")
    onnx.checker.check_model(m)
    return m


def check(tflite_bytes, onnx_model, crops):
    """Largest difference between the two models' landmarks over `crops` (NHWC in [0, 1])."""
    from onnx.reference import ReferenceEvaluator
    try:
        from ai_edge_litert.interpreter import Interpreter
    except ImportError:
        print("ai-edge-litert not installed: skipping the comparison with TFLite")
        return
    interp = Interpreter(model_content=tflite_bytes)
    interp.allocate_tensors()
    ref = ReferenceEvaluator(onnx_model)
    worst = 0.0
    for crop in crops:
        interp.set_tensor(interp.get_input_details()[0]["index"], crop[None].astype(np.float32))
        interp.invoke()
        expected = {d["name"]: interp.get_tensor(d["index"]) for d in interp.get_output_details()}
        got = ref.run(None, {"image": crop.transpose(2, 0, 1)[None].astype(np.float32)})
        worst = max(worst, float(np.abs(got[0].reshape(-1) - expected["conv2d_21"].reshape(-1)).max()),
                    float(np.abs(got[1].reshape(-1) - expected["conv2d_31"].reshape(-1)).max()))
    print(f"largest difference from TFLite over {len(crops)} crops: {worst:.2e}")
    if worst > 1e-2:
        raise SystemExit("the ONNX model does not agree with the TFLite model")


def main():
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    source, target = sys.argv[1], sys.argv[2]
    if source.endswith(".whl"):
        with zipfile.ZipFile(source) as wheel:
            tflite_bytes = wheel.read(MEMBER)
    else:
        tflite_bytes = open(source, "rb").read()
    model = convert(tflite_bytes)
    rng = np.random.default_rng(7)
    crops = [rng.random((192, 192, 3), dtype=np.float32) for _ in range(2)]
    for path in sys.argv[3:]:
        from PIL import Image
        crops.append(np.asarray(Image.open(path).convert("RGB").resize((192, 192)), np.float32) / 255)
    check(tflite_bytes, model, crops)
    onnx.save(model, target)
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
