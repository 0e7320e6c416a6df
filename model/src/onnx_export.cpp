// UNetGenerator -> ONNX ModelProto in protobuf's wire format
// (onnx/onnx.proto3 field numbers; protobuf's encoding guide for varints,
// length-delimited fields and packed repeated fields).
#include "reefgen/model/onnx_export.hpp"

#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "reefgen/error.hpp"
#include "reefgen/files.hpp"
#include "reefgen/version.hpp"

namespace reefgen::model {
namespace {

// One protobuf message being written: fields appended in any order.
class Message {
 public:
  void varint(int field, uint64_t v) {
    key(field, 0);
    raw_varint(v);
  }
  void bytes(int field, const std::string& b) {
    key(field, 2);
    raw_varint(b.size());
    out_ += b;
  }
  void message(int field, const Message& m) { bytes(field, m.out_); }
  void f32(int field, float v) {
    key(field, 5);
    char b[4];
    std::memcpy(b, &v, 4);
    out_.append(b, 4);
  }
  void packed_int64(int field, const std::vector<int64_t>& v) {
    Message m;
    for (int64_t x : v) m.raw_varint(uint64_t(x));
    bytes(field, m.out_);
  }
  const std::string& str() const { return out_; }

 private:
  void key(int field, int wire_type) { raw_varint(uint64_t(field) << 3 | uint64_t(wire_type)); }
  void raw_varint(uint64_t v) {
    while (v >= 0x80) out_.push_back(char((v & 0x7F) | 0x80)), v >>= 7;
    out_.push_back(char(v));
  }
  std::string out_;
};

// onnx.proto3's field numbers and enums, named once.
namespace pb {
constexpr int kModelIrVersion = 1, kModelProducerName = 2, kModelProducerVersion = 3, kModelGraph = 7,
              kModelOpsetImport = 8, kModelMetadata = 14;
constexpr int kEntryKey = 1, kEntryValue = 2;
constexpr int kOpsetDomain = 1, kOpsetVersion = 2;
constexpr int kGraphNode = 1, kGraphName = 2, kGraphInitializer = 5, kGraphInput = 11, kGraphOutput = 12;
constexpr int kNodeInput = 1, kNodeOutput = 2, kNodeName = 3, kNodeOpType = 4, kNodeAttribute = 5;
constexpr int kAttrName = 1, kAttrF = 2, kAttrI = 3, kAttrS = 4, kAttrInts = 8, kAttrType = 20;
constexpr int kAttrTypeFloat = 1, kAttrTypeInt = 2, kAttrTypeString = 3, kAttrTypeInts = 7;
constexpr int kTensorDims = 1, kTensorDataType = 2, kTensorName = 8, kTensorRawData = 9;
constexpr int kTensorFloat = 1;
constexpr int kValueName = 1, kValueType = 2, kTypeTensor = 1, kTensorTypeElem = 1, kTensorTypeShape = 2;
constexpr int kShapeDim = 1, kDimValue = 1;
}  // namespace pb

struct Attr {
  std::string name;
  enum Kind { Int, Float, String, Ints } kind;
  int64_t i = 0;
  float f = 0;
  std::string s;
  std::vector<int64_t> ints;
};
Attr attr_i(std::string n, int64_t v) { return {std::move(n), Attr::Int, v, 0, {}, {}}; }
Attr attr_f(std::string n, float v) { return {std::move(n), Attr::Float, 0, v, {}, {}}; }
Attr attr_s(std::string n, std::string v) { return {std::move(n), Attr::String, 0, 0, std::move(v), {}}; }
Attr attr_ints(std::string n, std::vector<int64_t> v) { return {std::move(n), Attr::Ints, 0, 0, {}, std::move(v)}; }

Message attribute(const Attr& a) {
  Message m;
  m.bytes(pb::kAttrName, a.name);
  switch (a.kind) {
    case Attr::Int: m.varint(pb::kAttrI, uint64_t(a.i)), m.varint(pb::kAttrType, pb::kAttrTypeInt); break;
    case Attr::Float: m.f32(pb::kAttrF, a.f), m.varint(pb::kAttrType, pb::kAttrTypeFloat); break;
    case Attr::String: m.bytes(pb::kAttrS, a.s), m.varint(pb::kAttrType, pb::kAttrTypeString); break;
    case Attr::Ints:
      for (int64_t v : a.ints) m.varint(pb::kAttrInts, uint64_t(v));
      m.varint(pb::kAttrType, pb::kAttrTypeInts);
      break;
  }
  return m;
}

Message float_tensor(const std::string& name, const torch::Tensor& t) {
  const torch::Tensor c = t.detach().to(torch::kFloat32).contiguous();
  Message m;
  m.packed_int64(pb::kTensorDims, c.sizes().vec());
  m.varint(pb::kTensorDataType, pb::kTensorFloat);
  m.bytes(pb::kTensorName, name);
  // ONNX raw_data is little-endian, as x86 stores floats.
  m.bytes(pb::kTensorRawData, std::string(reinterpret_cast<const char*>(c.data_ptr<float>()), size_t(c.numel()) * 4));
  return m;
}

Message float_value(const std::string& name, const std::vector<int64_t>& dims) {
  Message shape;
  for (int64_t d : dims) {
    Message dim;
    dim.varint(pb::kDimValue, uint64_t(d));
    shape.message(pb::kShapeDim, dim);
  }
  Message tensor_type;
  tensor_type.varint(pb::kTensorTypeElem, pb::kTensorFloat);
  tensor_type.message(pb::kTensorTypeShape, shape);
  Message type;
  type.message(pb::kTypeTensor, tensor_type);
  Message v;
  v.bytes(pb::kValueName, name);
  v.message(pb::kValueType, type);
  return v;
}

// The graph being built: nodes in execution order, weights as initializers,
// every intermediate value given a fresh name.
class Graph {
 public:
  explicit Graph(std::map<std::string, torch::Tensor> weights) : weights_(std::move(weights)) {}

  // The node's output is a fresh name, or `out` when given (the graph's own output).
  std::string node(const std::string& op, const std::vector<std::string>& inputs, const std::vector<Attr>& attrs = {},
                   std::string out = "") {
    if (out.empty()) out = op + "_" + std::to_string(++count_);
    Message n;
    for (const auto& i : inputs) n.bytes(pb::kNodeInput, i);
    n.bytes(pb::kNodeOutput, out);
    n.bytes(pb::kNodeName, out);
    n.bytes(pb::kNodeOpType, op);
    for (const auto& a : attrs) n.message(pb::kNodeAttribute, attribute(a));
    graph_.message(pb::kGraphNode, n);
    return out;
  }
  // A stored weight by its module name, as an initializer (once).
  bool has(const std::string& name) const { return weights_.count(name) > 0; }
  std::string weight(const std::string& name) {
    const auto it = weights_.find(name);
    if (it == weights_.end()) throw Error("ONNX export: the generator has no tensor " + name);
    return constant(name, it->second);
  }
  std::string constant(const std::string& name, const torch::Tensor& t) {
    if (written_.insert(name).second) graph_.message(pb::kGraphInitializer, float_tensor(name, t));
    return name;
  }
  Message& proto() { return graph_; }

 private:
  std::map<std::string, torch::Tensor> weights_;
  std::set<std::string> written_;
  Message graph_;
  int count_ = 0;
};

constexpr double kNormEps = 1e-5;  // BatchNorm2d's and InstanceNorm2d's default eps (networks.cpp keeps them)

std::string conv(Graph& g, const std::string& x, const std::string& prefix, int kernel, int stride, int pad,
                 bool transposed) {
  std::vector<std::string> in{x, g.weight(prefix + ".weight")};
  if (g.has(prefix + ".bias")) in.push_back(g.weight(prefix + ".bias"));
  return g.node(transposed ? "ConvTranspose" : "Conv", in,
                {attr_ints("kernel_shape", {kernel, kernel}), attr_ints("strides", {stride, stride}),
                 attr_ints("pads", {pad, pad, pad, pad}), attr_ints("dilations", {1, 1}), attr_i("group", 1)});
}

// The norm layer registered at `prefix` (down_norm / up_norm) over `channels`.
std::string norm(Graph& g, const std::string& x, const std::string& prefix, Norm n, int64_t channels,
                 bool running_stats) {
  if (n == Norm::None) return x;
  const std::string bn = prefix + ".bn";
  if (n == Norm::Batch && running_stats)
    return g.node("BatchNormalization",
                  {x, g.weight(bn + ".weight"), g.weight(bn + ".bias"), g.weight(bn + ".running_mean"),
                   g.weight(bn + ".running_var")},
                  {attr_f("epsilon", float(kNormEps))});
  // One sample's own statistics: InstanceNorm2d (affine=False: scale 1, bias 0),
  // or BatchNorm2d in batch-statistics mode (its affine γ, β).
  const std::string scale = n == Norm::Batch ? g.weight(bn + ".weight")
                                             : g.constant(prefix + ".ones", torch::ones({channels}));
  const std::string bias = n == Norm::Batch ? g.weight(bn + ".bias")
                                            : g.constant(prefix + ".zeros", torch::zeros({channels}));
  return g.node("InstanceNormalization", {x, scale, bias}, {attr_f("epsilon", float(kNormEps))});
}

// The decoder's ×2: a 4×4 stride-2 transposed convolution, or resize (as
// torch's interpolate with scale 2, align_corners false) then a 3×3 convolution.
std::string up(Graph& g, const std::string& x, const std::string& prefix, Upsample u) {
  if (u == Upsample::Transpose) return conv(g, x, prefix, 4, 2, 1, true);
  const std::string scales = g.constant("resize_scales", torch::tensor({1.0f, 1.0f, 2.0f, 2.0f}));
  const std::vector<Attr> attrs =
      u == Upsample::Nearest
          ? std::vector<Attr>{attr_s("mode", "nearest"), attr_s("coordinate_transformation_mode", "asymmetric"),
                              attr_s("nearest_mode", "floor")}
          : std::vector<Attr>{attr_s("mode", "linear"), attr_s("coordinate_transformation_mode", "half_pixel")};
  return conv(g, g.node("Resize", {x, "", scales}, attrs), prefix, 3, 1, 1, false);
}

void check_side(const UNetOptions& o, int size_px) {
  const int multiple = 1 << o.depth;
  if (size_px < 32 || size_px > 4096 || size_px % multiple)
    throw Error("ONNX export: --size " + std::to_string(size_px) + " must be in [32, 4096] and a multiple of " +
                std::to_string(multiple) + " (2^depth of this generator)");
}

}  // namespace

std::string generator_onnx(UNetGeneratorImpl& net, const HeightRange& range, const OnnxExportOptions& opt) {
  const UNetOptions& o = net.options();
  check_side(o, opt.size_px);
  std::map<std::string, torch::Tensor> weights;
  for (const auto& p : net.named_parameters()) weights[p.key()] = p.value();
  for (const auto& b : net.named_buffers()) weights[b.key()] = b.value();
  Graph g(std::move(weights));
  const int depth = o.depth;
  auto level = [](int k) { return "levels." + std::to_string(k); };
  auto channels = [&](int k) { return int64_t(o.ngf) * std::min(1 << std::min(k, 3), 8); };

  // Down path (networks.cpp UNetGeneratorImpl::logits): the skips carry leaky(d).
  std::vector<std::string> skips;
  std::string d = conv(g, "label", level(0) + ".down_conv", 4, 2, 1, false);
  for (int k = 1; k < depth; ++k) {
    const std::string a = g.node("LeakyRelu", {d}, {attr_f("alpha", 0.2f)});
    skips.push_back(a);
    d = conv(g, a, level(k) + ".down_conv", 4, 2, 1, false);
    if (k < depth - 1) d = norm(g, d, level(k) + ".down_norm", o.norm, channels(k), opt.running_stats);
  }
  // Up path, innermost first, each level's answer after its skip.
  std::string u = d;
  for (int k = depth - 1; k >= 1; --k) {
    u = up(g, g.node("Relu", {u}), level(k) + ".up_conv", o.upsample);
    u = norm(g, u, level(k) + ".up_norm", o.norm, channels(k - 1), opt.running_stats);
    u = g.node("Concat", {skips[size_t(k - 1)], u}, {attr_i("axis", 1)});
  }
  const std::string y = g.node("Tanh", {up(g, g.node("Relu", {u}), level(0) + ".up_conv", o.upsample)});
  // Metres: lo + (y + 1)/2 · (hi − lo) = y · half + mid (codec.hpp's map).
  const float half = float((range.hi_m - range.lo_m) / 2), mid = float((range.hi_m + range.lo_m) / 2);
  const std::string scaled = g.node("Mul", {y, g.constant("height_half_span_m", torch::tensor({half}))});
  g.node("Add", {scaled, g.constant("height_middle_m", torch::tensor({mid}))}, {}, "height_m");

  const int64_t S = opt.size_px;
  g.proto().bytes(pb::kGraphName, "reefgen_generator");
  g.proto().message(pb::kGraphInput, float_value("label", {1, o.in_channels, S, S}));
  g.proto().message(pb::kGraphOutput, float_value("height_m", {1, o.out_channels, S, S}));

  Message opset;
  opset.bytes(pb::kOpsetDomain, "");
  opset.varint(pb::kOpsetVersion, uint64_t(kOnnxOpset));
  Message model;
  model.varint(pb::kModelIrVersion, uint64_t(kOnnxIrVersion));
  model.bytes(pb::kModelProducerName, "reefgen");
  model.bytes(pb::kModelProducerVersion, kVersion);
  model.message(pb::kModelGraph, g.proto());
  model.message(pb::kModelOpsetImport, opset);
  // What a runtime's user needs beside the graph (read back by onnx's
  // metadata_props, ONNX Runtime's modelmeta, Sentis' model info).
  const std::vector<std::pair<std::string, std::string>> meta = {
      {"input", "label: the 8-bit RGB label map as a dataset pair holds it (docs/DATASET.md), v / 127.5 - 1, NCHW"},
      {"output", "height_m: metres above sea level, NCHW"},
      {"height_range_m", std::to_string(range.lo_m) + " " + std::to_string(range.hi_m)},
      {"normalisation", o.norm == Norm::None       ? "none"
                        : opt.running_stats        ? "running statistics"
                                                   : "the sample's own statistics (pix2pix test-time mode)"},
      {"size_px", std::to_string(opt.size_px)}};
  for (const auto& [k, v] : meta) {
    Message e;
    e.bytes(pb::kEntryKey, k);
    e.bytes(pb::kEntryValue, v);
    model.message(pb::kModelMetadata, e);
  }
  return model.str();
}

void write_generator_onnx(const std::filesystem::path& path, UNetGeneratorImpl& g, const HeightRange& range,
                          const OnnxExportOptions& options) {
  const std::string bytes = generator_onnx(g, range, options);
  write_file_atomic(path, bytes.data(), bytes.size());
}

}  // namespace reefgen::model
