#!/usr/bin/env python3
"""Convert MediaPipe's face detection, face landmark, iris landmark and
attention face landmark TFLite models to ONNX, so that eyereplay can run
them with ONNX Runtime.

Why our own converter: tflite2onnx crashes on face_landmark's PReLU weights
and tract-tflite lacks fp16 DEQUANTIZE and PRELU. These graphs use a dozen
TFLite operators, all handled below, and the attention mesh three of
MediaPipe's own (Landmarks2TransformMatrix, TransformTensorBilinear,
TransformLandmarks, version 2), which are left to the caller between a
face model and an eye model (--split-eyes, see Converter.split_eyes).

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
       tflite_to_onnx.py face_landmark_with_attention.tflite FACE.onnx --split-eyes EYES.onnx
(--split-eyes: the attention mesh as a face model and an eye model, its
custom operators left to the caller, the lips dropped.)
"""
import sys

import numpy as np
import onnx
import tflite
from flatbuffers import flexbuffers
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
        # The attention mesh's custom operators, recorded as met and left
        # to the caller (see `split_eyes`).
        self.l2tm = {}  # matrix tensor -> (landmarks tensor, attributes)
        self.ttb = {}  # crop tensor -> (feature map tensor, matrix tensor, NCHW shape)
        self.tl = {}  # output tensor -> (landmarks tensor, matrix tensor)
        self.mul_const = {}  # MUL output -> (input tensor, constant)

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
        """The ONNX model; for the attention face mesh, whose custom
        operators ONNX has not, its face and eye models (`split_eyes`)."""
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

        self.shape_of = {self.tname(i): self.shape(i) for i in range(g.TensorsLength())}
        self.reshape_of = {}  # RESHAPE output -> its input
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
                cin = self.shape(ins[0])[3]
                if not p[:3].any() and p[3, 0] == 0 and cin % 16 == 0:
                    # Zeros appended to the channels (the residual blocks'
                    # skip path as the channels grow): a 1x1 convolution
                    # with identity weights, the same values exactly.
                    # ONNX Runtime's NCHWc layout takes no Pad, and a Pad
                    # left the residual Adds after it, and their PReLUs, in
                    # NCHW between layout reorders.
                    cout = cin + int(p[3, 1])
                    eye = np.zeros((cout, cin, 1, 1), np.float32)
                    eye[np.arange(cin), np.arange(cin)] = 1.0
                    self.node("Conv", [src(ins[0]), self.add_const(out + "_w", eye),
                                       self.add_const(out + "_b", np.zeros(cout, np.float32))], [out],
                              kernel_shape=[1, 1])
                    continue
                order = [0, 3, 1, 2]  # NCHW <- NHWC
                pads = np.array([p[i, 0] for i in order] + [p[i, 1] for i in order], dtype=np.int64)
                self.node("Pad", [src(ins[0]), self.add_const(out + "_pads", pads)], [out], mode="constant")
            elif name == "RESHAPE":
                self.reshape_of[out] = src(ins[0])
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
            elif name == "MUL":
                o = self.opts(op, tflite.MulOptions)
                if len(self.shape(ins[0])) == 4 or len(self.shape(ins[1])) == 4:
                    raise SystemExit("MUL on 4-D tensors is not handled (layout)")
                b = self.const(ins[1])
                if b is not None:
                    self.mul_const[out] = (src(ins[0]), b.astype(np.float32))
                b = self.add_const(out + "_k", b.astype(np.float32)) if b is not None else src(ins[1])
                pre = self.activation(out, o.FusedActivationFunction())
                self.node("Mul", [src(ins[0]), b], [pre])
            elif name == "STRIDED_SLICE":
                begin, end, strides = (self.const(i) for i in ins[1:4])
                full = self.shape(ins[0])
                if not ((begin == 0).all() and (strides == 1).all() and list(end) == full):
                    raise SystemExit("only a STRIDED_SLICE that keeps the whole tensor is handled")
                self.node("Identity", [src(ins[0])], [out])
            elif name == "CUSTOM":
                custom = oc.CustomCode().decode()
                attrs = flexbuffers.Loads(bytes(op.CustomOptionsAsNumpy())) if op.CustomOptionsLength() else {}
                if custom == "Landmarks2TransformMatrix" and oc.Version() == 2:
                    self.l2tm[out] = (src(ins[0]), attrs)
                elif custom == "TransformTensorBilinear" and oc.Version() == 2:
                    _, oh, ow, ch = self.shape(outs[0])
                    self.ttb[out] = (src(ins[0]), src(ins[1]), [ch, oh, ow])
                elif custom == "TransformLandmarks" and oc.Version() == 2:
                    self.tl[out] = (src(ins[0]), src(ins[1]))
                else:
                    raise SystemExit(f"unsupported custom operator {custom} v{oc.Version()}")
            else:
                raise SystemExit(f"unsupported operator {name}")

        self.graph_input = graph_input
        if self.l2tm or self.ttb or self.tl:
            return self.split_eyes()
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

        return self.build([graph_input], outputs, self.nodes)

    def build(self, inputs, outputs, nodes, metadata=None):
        """A model of `nodes` pruned to what `outputs` need (in their order;
        a node whose inputs are graph `inputs` starts there)."""
        needed = {o.name for o in outputs}
        kept = []
        for nd in reversed(nodes):
            if any(o in needed for o in nd.output):
                kept.append(nd)
                needed.update(nd.input)
        kept = kept[::-1]
        produced = {o for nd in kept for o in nd.output} | {i.name for i in inputs}
        # Keep only the constants that a node reads (DEQUANTIZE outputs that
        # fed weights are already folded into transposed copies).
        used = {i for nd in kept for i in nd.input}
        missing = used - produced - set(self.inits) - {""}
        if missing:
            raise SystemExit(f"the graph needs tensors it does not have: {sorted(missing)[:5]}")
        inits = [numpy_helper.from_array(np.asarray(v), k) for k, v in self.inits.items() if k in used]
        graph = helper.make_graph(kept, "mediapipe", inputs, outputs, inits)
        m = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)],
                              producer_name="eyereplay tflite_to_onnx")
        m.ir_version = 8
        for k, v in (metadata or {}).items():
            helper.set_model_props(m, {**{p.key: p.value for p in m.metadata_props}, k: v})
        onnx.checker.check_model(m)
        return m

    def split_eyes(self):
        """The attention face mesh as two models, its custom operators left
        to the caller (eyereplay's `Models::attention`, after MediaPipe's
        reference kernels): ONNX Runtime ran the in-graph versions as about
        a hundred tiny operators (matrix arithmetic, GridSample), a sixth of
        the network's time.

        The face model: "input" -> the mesh, the face flag and
        "eye_features" (the feature map the eye crops are read from, NCHW).
        The eye model: "left_eye_features", "right_eye_features" (each
        eye's crop of that map, NCHW) -> "left_eye", "left_iris",
        "right_eye", "right_iris" (points in the crop's frame, before
        TransformLandmarks). Its metadata says, per eye, how the crop is
        placed ("<eye>.crop": Landmarks2TransformMatrix's attributes and the
        factor the mesh is scaled by first) and how the points return to the
        face crop ("<eye>.points": the factors the matrix is multiplied by,
        elementwise, row-major 4 x 4)."""
        def flat_output(name, new):
            shp = self.shape_of[name]
            self.nodes.append(helper.make_node("Reshape", [name, self.add_const("flat", np.array([-1, int(np.prod(shp[1:]))], dtype=np.int64))], [new]))
            return helper.make_tensor_value_info(new, TensorProto.FLOAT, ["batch", int(np.prod(shp[1:]))])

        features = {f for f, _, _ in self.ttb.values()}
        if len(features) != 1:
            raise SystemExit("expected one feature map under the eye crops")
        feature = features.pop()
        feature_shape = self.shape_of[feature]
        self.nodes.append(helper.make_node("Identity", [feature], ["eye_features"]))
        face_outputs = [flat_output("output_mesh_identity", "output_mesh_identity_flat"),
                        flat_output("conv_faceflag", "conv_faceflag_flat"),
                        helper.make_tensor_value_info("eye_features", TensorProto.FLOAT,
                                                      ["batch"] + [feature_shape[3]] + feature_shape[1:3])]
        face = self.build([self.graph_input], face_outputs, self.nodes)

        eye_inputs, eye_outputs, meta = [], [], {}
        for side in ("left", "right"):
            points = {}
            for part in ("eye", "iris"):
                # output_<side>_<part> = RESHAPE(TransformLandmarks(p, M'))
                tl_out = next(t for t, _ in self.tl.items()
                              if self.reshape_of.get(f"output_{side}_{part}") == t)
                p, m_scaled = self.tl[tl_out]
                points[part] = m_scaled
                self.nodes.append(helper.make_node("Identity", [p], [f"{side}_{part}"]))
                eye_outputs.append(helper.make_tensor_value_info(
                    f"{side}_{part}", TensorProto.FLOAT, ["batch"] + self.shape_of[p][1:]))
            if points["eye"] != points["iris"]:
                raise SystemExit(f"{side}: eye and iris points use different matrices")
            matrix, scale = self.mul_const[points["eye"]]
            crop = next(t for t, (_, mt, _) in self.ttb.items() if mt == matrix)
            lm, attrs = self.l2tm[matrix]
            mesh_src, lm_scale = self.mul_const[lm]
            ch, oh, ow = self.ttb[crop][2]
            # First in the node list: the pruning walks it backwards once.
            self.nodes.insert(0, helper.make_node("Identity", [f"{side}_eye_features"], [crop]))
            eye_inputs.append(helper.make_tensor_value_info(f"{side}_eye_features", TensorProto.FLOAT, ["batch", ch, oh, ow]))
            a = dict(attrs)
            meta[f"{side}.crop"] = " ".join(
                [f"{k}={a[k]}" for k in ("left_rotation_idx", "right_rotation_idx", "output_width",
                                        "output_height", "scale_x", "scale_y", "target_rotation_radians")]
                + [f"landmark_scale={float(lm_scale.reshape(-1)[0])}",
                   "subset_idxs=" + ",".join(str(i) for i in a["subset_idxs"])])
            meta[f"{side}.points"] = "matrix_scale=" + ",".join(str(float(v)) for v in scale.reshape(-1))
        eyes = self.build(eye_inputs, eye_outputs, self.nodes, meta)
        return face, merge_branches(eyes, "left_eye_features", "right_eye_features")


MERGEABLE = {"Conv", "BatchNormalization", "Relu", "Add", "MaxPool"}


def merge_branches(model, left_input, right_input):
    """Two branches of the same architecture (the attention mesh's left and
    right eye networks, each from its own graph input) as one, channels
    side by side: each convolution grouped in two (a depthwise one keeps
    one group per channel), per-channel parameters concatenated, and the
    branches' own tails (transposes and reshapes of their outputs) fed by
    their halves. The same arithmetic per channel, so the same outputs;
    ONNX Runtime ran the eyes' 16x16 networks as some 300 operators of a
    few microseconds each, the merged one has half as many."""
    g = model.graph
    inits = {i.name: numpy_helper.to_array(i) for i in g.initializer}

    def branch(start):
        reach, nodes = {start}, []
        for nd in g.node:
            if nd.op_type in MERGEABLE and any(i in reach for i in nd.input):
                reach.update(nd.output)
                nodes.append(nd)
        return nodes

    # Past the renaming Identity at each input.
    def start(name):
        return next((nd.output[0] for nd in g.node if nd.op_type == "Identity" and nd.input[0] == name), name)

    shapes = {i.name: [d.dim_value for d in i.type.tensor_type.shape.dim] for i in g.input}
    in_channels = shapes[left_input][1]
    left_input, right_input = start(left_input), start(right_input)
    lefts, rights = branch(left_input), branch(right_input)
    if len(lefts) != len(rights) or not lefts:
        raise SystemExit("the eye branches differ in size")
    pair = {left_input: right_input}  # left tensor -> right tensor
    merged_of = {left_input: "merged_input"}  # left tensor -> merged tensor
    channels = {left_input: in_channels}  # left tensor -> its channels
    out_nodes = [helper.make_node("Concat", [left_input, right_input], ["merged_input"], axis=1)]
    new_inits = {}
    for a, b in zip(lefts, rights):
        attrs_a = {x.name: helper.get_attribute_value(x) for x in a.attribute}
        attrs_b = {x.name: helper.get_attribute_value(x) for x in b.attribute}
        if a.op_type != b.op_type or attrs_a != attrs_b or len(a.input) != len(b.input):
            raise SystemExit(f"the eye branches differ at {a.name or a.output[0]}")
        ins = []
        for ia, ib in zip(a.input, b.input):
            if ia in inits:
                wa, wb = inits[ia], inits[ib]
                if wa.shape != wb.shape:
                    raise SystemExit(f"the eye branches' weights differ in shape at {ia}")
                name = "m_" + ia
                new_inits[name] = np.concatenate([wa, wb], axis=0)
                ins.append(name)
            else:
                if pair.get(ia) != ib:
                    raise SystemExit(f"the eye branches are wired differently at {ia}")
                ins.append(merged_of[ia])
        out = "m_" + a.output[0]
        attrs = dict(attrs_a)
        if a.op_type == "Conv":
            attrs["group"] = 2 * attrs.get("group", 1)
            c_out = inits[a.input[1]].shape[0]
        else:
            c_out = channels[a.input[0]]
        out_nodes.append(helper.make_node(a.op_type, ins, [out], **attrs))
        pair[a.output[0]] = b.output[0]
        merged_of[a.output[0]] = out
        channels[a.output[0]] = c_out
    # The rest (the branches' tails) as it was, reading its branch's half.
    right_of = {v: k for k, v in pair.items()}
    merged_nodes = {id(n) for n in lefts + rights}
    for nd in g.node:
        if id(nd) in merged_nodes:
            continue
        ins = list(nd.input)
        for k, t in enumerate(ins):
            # A tensor of the merged part: which half, and its left name.
            if t in merged_of and t != left_input:
                side, left_name = 0, t
            elif right_of.get(t) in merged_of and right_of[t] != left_input:
                side, left_name = 1, right_of[t]
            else:
                continue
            c = channels[left_name]
            half = f"{t}_half"
            starts = numpy_helper.from_array(np.array([side * c], np.int64), half + "_s")
            ends = numpy_helper.from_array(np.array([(side + 1) * c], np.int64), half + "_e")
            axes = numpy_helper.from_array(np.array([1], np.int64), half + "_a")
            for init in (starts, ends, axes):
                new_inits[init.name] = numpy_helper.to_array(init)
            out_nodes.append(helper.make_node("Slice", [merged_of[left_name], starts.name, ends.name, axes.name], [half]))
            ins[k] = half
        out_nodes.append(helper.make_node(nd.op_type, ins, list(nd.output), name=nd.name,
                                          **{x.name: helper.get_attribute_value(x) for x in nd.attribute}))
    # Topological order (the Concat came first, before the renaming
    # Identities it reads).
    ready = {i.name for i in g.input} | set(inits) | set(new_inits) | {""}
    ordered, pending = [], out_nodes
    while pending:
        later = [nd for nd in pending if not all(i in ready for i in nd.input)]
        done = [nd for nd in pending if all(i in ready for i in nd.input)]
        if not done:
            raise SystemExit("the merged eye graph has a cycle")
        for nd in done:
            ready.update(nd.output)
        ordered += done
        pending = later
    out_nodes = ordered
    used = {i for nd in out_nodes for i in nd.input}
    keep = {k: v for k, v in inits.items() if k in used}
    keep.update({k: v for k, v in new_inits.items() if k in used})
    graph = helper.make_graph(out_nodes, g.name, list(g.input), list(g.output),
                              [numpy_helper.from_array(np.asarray(v), k) for k, v in keep.items()])
    m = helper.make_model(graph, opset_imports=list(model.opset_import), producer_name=model.producer_name)
    m.ir_version = model.ir_version
    helper.set_model_props(m, {p.key: p.value for p in model.metadata_props})
    onnx.checker.check_model(m)
    return m


def main():
    args = sys.argv[1:]
    eyes_out = None
    if len(args) == 4 and args[2] == "--split-eyes":
        eyes_out = args[3]
        args = args[:2]
    if len(args) != 2:
        raise SystemExit(__doc__)
    with open(args[0], "rb") as f:
        buf = f.read()
    result = Converter(buf).run()
    if isinstance(result, tuple) != (eyes_out is not None):
        raise SystemExit(f"{args[0]}: --split-eyes is for the attention face mesh, and it needs it")
    if eyes_out:
        onnx.save(result[0], args[1])
        onnx.save(result[1], eyes_out)
    else:
        onnx.save(result, args[1])


if __name__ == "__main__":
    main()
