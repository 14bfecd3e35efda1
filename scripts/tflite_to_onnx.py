#!/usr/bin/env python3
"""Convert MediaPipe's face detection, face landmark and iris landmark
TFLite models to ONNX, so that eyereplay can run them with ONNX Runtime.

Why our own converter: tflite2onnx crashes on face_landmark's PReLU weights
and tract-tflite lacks fp16 DEQUANTIZE and PRELU (see shared RESEARCH.md).
These three graphs use only ten TFLite operators, all handled below.

Layout: TFLite is NHWC; the ONNX graph is NCHW throughout (ONNX Runtime's
convolutions are NCHW), with an NCHW float input named "input" whose batch
dimension is symbolic (so both eye crops go through the iris model in one
call). A 4-D tensor is transposed back to NHWC only before a RESHAPE, whose
element order is defined on the NHWC layout.

PReLU is written as x + (1 - a) * Relu(-x), with the two per-channel scales
as BatchNormalization nodes (scale -1, then 1 - a; mean 0, variance 1,
epsilon 0): the same function (slopes range from -1.6 to 1.5, so Max(x, a*x)
would be wrong). Why: ONNX Runtime's NCHWc layout pass (the fastest CPU
path) cannot take PRelu, nor Min/Mul with broadcast constants, so it wrapped
every PReLU in layout reorders that cost 37 % of the iris model's time;
BatchNormalization becomes an NCHWc depthwise 1x1 convolution with the Relu
fused. Measured with ONNX Runtime 1.22.1, one thread, CPU time per
inference: iris (2 eyes) 2.6-2.9 ms with PRelu -> 1.9-2.0 ms; mesh 1.3-1.4
-> 0.9 ms; outputs equal to 2e-5.

Usage: tflite_to_onnx.py IN.tflite OUT.onnx
"""
import sys

import numpy as np
import onnx
import tflite
from onnx import TensorProto, helper, numpy_helper

OPNAME = {v: k for k, v in tflite.BuiltinOperator.__dict__.items() if not k.startswith("_")}
NP_TYPE = {
    tflite.TensorType.FLOAT32: np.float32,
    tflite.TensorType.FLOAT16: np.float16,
    tflite.TensorType.INT32: np.int32,
    tflite.TensorType.INT64: np.int64,
}


class Converter:
    def __init__(self, buf):
        self.model = tflite.Model.GetRootAsModel(buf, 0)
        if self.model.SubgraphsLength() != 1:
            raise SystemExit("expected one subgraph")
        self.g = self.model.Subgraphs(0)
        self.nodes = []
        self.inits = {}  # name -> np.ndarray (constants)
        self.uid = 0

    # -- helpers -----------------------------------------------------------
    def tname(self, i):
        return self.g.Tensors(i).Name().decode()

    def shape(self, i):
        return [int(d) for d in self.g.Tensors(i).ShapeAsNumpy()]

    def const(self, i):
        """The constant value of tensor i (None if it is computed)."""
        name = self.tname(i)
        if name in self.inits:
            return self.inits[name]
        t = self.g.Tensors(i)
        b = self.model.Buffers(t.Buffer())
        if b.DataLength() == 0:
            return None
        arr = np.frombuffer(b.DataAsNumpy().tobytes(), dtype=NP_TYPE[t.Type()])
        return arr.reshape(self.shape(i)) if self.shape(i) else arr

    def fresh(self, base):
        self.uid += 1
        return f"{base}__{self.uid}"

    def add_const(self, base, arr):
        name = self.fresh(base)
        self.inits[name] = arr
        return name

    def node(self, op, inputs, outputs, **attrs):
        self.nodes.append(helper.make_node(op, inputs, outputs, **attrs))

    def activation(self, out, fused):
        """Emit the op's fused activation; returns the pre-activation name."""
        if fused == tflite.ActivationFunctionType.NONE:
            return out
        pre = self.fresh(out + "_pre")
        if fused == tflite.ActivationFunctionType.RELU:
            self.node("Relu", [pre], [out])
        elif fused == tflite.ActivationFunctionType.RELU6:
            self.node("Clip", [pre, self.add_const("lo", np.float32(0)),
                               self.add_const("hi", np.float32(6))], [out])
        else:
            raise SystemExit(f"unsupported fused activation {fused}")
        return pre

    @staticmethod
    def same_pads(in_hw, k_hw, s_hw, d_hw=(1, 1)):
        """TensorFlow SAME padding: the odd pixel goes at the end."""
        pads_b, pads_e = [], []
        for n, k, s, d in zip(in_hw, k_hw, s_hw, d_hw):
            out = (n + s - 1) // s
            ke = (k - 1) * d + 1
            total = max((out - 1) * s + ke - n, 0)
            pads_b.append(total // 2)
            pads_e.append(total - total // 2)
        return pads_b + pads_e

    def opts(self, op, cls):
        o = cls()
        t = op.BuiltinOptions()
        o.Init(t.Bytes, t.Pos)
        return o

    # -- conversion ---------------------------------------------------------
    def run(self):
        g = self.g
        if g.InputsLength() != 1:
            raise SystemExit("expected one input")
        in_idx = g.Inputs(0)
        n, h, w, c = self.shape(in_idx)
        graph_input = helper.make_tensor_value_info("input", TensorProto.FLOAT, ["batch", c, h, w])
        # Rename the model input so that the NCHW tensor feeds every consumer.
        alias = {self.tname(in_idx): "input"}

        def src(i):
            nm = self.tname(i)
            return alias.get(nm, nm)

        for k in range(g.OperatorsLength()):
            op = g.Operators(k)
            oc = self.model.OperatorCodes(op.OpcodeIndex())
            code = max(oc.BuiltinCode(), oc.DeprecatedBuiltinCode())
            name = OPNAME.get(code, str(code))
            ins = [op.Inputs(j) for j in range(op.InputsLength())]
            outs = [op.Outputs(j) for j in range(op.OutputsLength())]
            out = self.tname(outs[0])

            if name == "DEQUANTIZE":
                # fp16 weights stored as constants: fold to fp32 here.
                self.inits[out] = self.const(ins[0]).astype(np.float32)
            elif name == "CONV_2D":
                o = self.opts(op, tflite.Conv2DOptions)
                wgt = self.const(ins[1]).astype(np.float32)  # O,H,W,I
                kh, kw = wgt.shape[1:3]
                wname = self.add_const(out + "_w", np.ascontiguousarray(wgt.transpose(0, 3, 1, 2)))
                bname = self.add_const(out + "_b", self.const(ins[2]).astype(np.float32))
                in_hw = self.shape(ins[0])[1:3]
                d = (o.DilationHFactor(), o.DilationWFactor())
                s = (o.StrideH(), o.StrideW())
                pads = self.same_pads(in_hw, (kh, kw), s, d) if o.Padding() == tflite.Padding.SAME else [0, 0, 0, 0]
                pre = self.activation(out, o.FusedActivationFunction())
                self.node("Conv", [src(ins[0]), wname, bname], [pre], kernel_shape=[kh, kw],
                          strides=list(s), dilations=list(d), pads=pads)
            elif name == "DEPTHWISE_CONV_2D":
                o = self.opts(op, tflite.DepthwiseConv2DOptions)
                wgt = self.const(ins[1]).astype(np.float32)  # 1,H,W,C*M
                kh, kw, cm = wgt.shape[1:4]
                cin = self.shape(ins[0])[3]
                wname = self.add_const(out + "_w", np.ascontiguousarray(wgt.transpose(3, 0, 1, 2)))
                bname = self.add_const(out + "_b", self.const(ins[2]).astype(np.float32))
                in_hw = self.shape(ins[0])[1:3]
                d = (o.DilationHFactor(), o.DilationWFactor())
                s = (o.StrideH(), o.StrideW())
                pads = self.same_pads(in_hw, (kh, kw), s, d) if o.Padding() == tflite.Padding.SAME else [0, 0, 0, 0]
                pre = self.activation(out, o.FusedActivationFunction())
                self.node("Conv", [src(ins[0]), wname, bname], [pre], kernel_shape=[kh, kw],
                          strides=list(s), dilations=list(d), pads=pads, group=cin)
                assert cm % cin == 0
            elif name == "PRELU":
                alpha = self.const(ins[1]).astype(np.float32).reshape(-1)
                channels = alpha.size

                def vec(name, v):
                    return self.add_const(out + name, np.zeros(channels, np.float32) + v)

                zero, one = vec("_zero", 0.0), vec("_one", 1.0)
                negx, relu, scaled = self.fresh(out + "_negx"), self.fresh(out + "_relu"), self.fresh(out + "_scaled")
                self.node("BatchNormalization", [src(ins[0]), vec("_minus1", -1.0), zero, zero, one], [negx], epsilon=0.0)
                self.node("Relu", [negx], [relu])
                self.node("BatchNormalization", [relu, vec("_1ma", 1.0 - alpha), zero, zero, one], [scaled], epsilon=0.0)
                self.node("Add", [src(ins[0]), scaled], [out])
            elif name == "RELU":
                self.node("Relu", [src(ins[0])], [out])
            elif name == "ADD":
                o = self.opts(op, tflite.AddOptions)
                pre = self.activation(out, o.FusedActivationFunction())
                self.node("Add", [src(ins[0]), src(ins[1])], [pre])
            elif name == "MAX_POOL_2D":
                o = self.opts(op, tflite.Pool2DOptions)
                k = (o.FilterHeight(), o.FilterWidth())
                s = (o.StrideH(), o.StrideW())
                in_hw = self.shape(ins[0])[1:3]
                pads = self.same_pads(in_hw, k, s) if o.Padding() == tflite.Padding.SAME else [0, 0, 0, 0]
                if any(pads):
                    raise SystemExit("SAME max-pool with padding not handled")
                pre = self.activation(out, o.FusedActivationFunction())
                self.node("MaxPool", [src(ins[0])], [pre], kernel_shape=list(k), strides=list(s))
            elif name == "PAD":
                p = self.const(ins[1]).astype(np.int64)  # [4,2] NHWC
                if p[0].any():
                    raise SystemExit("padding the batch dimension is not handled")
                order = [0, 3, 1, 2]  # NCHW <- NHWC
                pads = np.array([p[i, 0] for i in order] + [p[i, 1] for i in order], dtype=np.int64)
                self.node("Pad", [src(ins[0]), self.add_const(out + "_pads", pads)], [out], mode="constant")
            elif name == "RESHAPE":
                in_shape = self.shape(ins[0])
                x = src(ins[0])
                if len(in_shape) == 4:
                    nhwc = self.fresh(out + "_nhwc")
                    self.node("Transpose", [x], [nhwc], perm=[0, 2, 3, 1])
                    x = nhwc
                target = self.shape(outs[0])
                # The batch dimension is symbolic in our graph.
                target = [-1] + target[1:]
                self.node("Reshape", [x, self.add_const(out + "_shape", np.array(target, dtype=np.int64))], [out])
            elif name == "CONCATENATION":
                o = self.opts(op, tflite.ConcatenationOptions)
                axis = o.Axis()
                rank = len(self.shape(ins[0]))
                if axis < 0:
                    axis += rank
                if rank == 4:
                    axis = [0, 2, 3, 1][axis]
                pre = self.activation(out, o.FusedActivationFunction())
                self.node("Concat", [src(i) for i in ins], [pre], axis=axis)
            else:
                raise SystemExit(f"unsupported operator {name}")

        outputs = []
        for j in range(g.OutputsLength()):
            i = g.Outputs(j)
            shp = self.shape(i)
            if len(shp) == 4:
                # 1x1 spatial conv outputs: NCHW and NHWC agree on element
                # order; flatten so the consumer sees [batch, values].
                flat = self.tname(i)
                newname = flat + "_flat"
                self.node("Reshape", [flat, self.add_const("flat", np.array([-1, int(np.prod(shp[1:]))], dtype=np.int64))], [newname])
                assert shp[1] == 1 and shp[2] == 1, "only 1x1 spatial 4-D outputs"
                outputs.append(helper.make_tensor_value_info(newname, TensorProto.FLOAT, ["batch", int(np.prod(shp[1:]))]))
            else:
                outputs.append(helper.make_tensor_value_info(self.tname(i), TensorProto.FLOAT, ["batch"] + shp[1:]))

        # Keep only the constants that a node reads (DEQUANTIZE outputs that
        # fed weights are already folded into transposed copies).
        used = {i for nd in self.nodes for i in nd.input}
        inits = [numpy_helper.from_array(np.asarray(v), k) for k, v in self.inits.items() if k in used]
        graph = helper.make_graph(self.nodes, "mediapipe", [graph_input], outputs, inits)
        m = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)],
                              producer_name="eyereplay tflite_to_onnx")
        m.ir_version = 8
        onnx.checker.check_model(m)
        return m


def main():
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    with open(sys.argv[1], "rb") as f:
        buf = f.read()
    m = Converter(buf).run()
    onnx.save(m, sys.argv[2])


if __name__ == "__main__":
    main()
