#include "engine/export/glb_tile.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>

#include <draco/compression/encode.h>
#include <draco/point_cloud/point_cloud_builder.h>

// tinygltf is Debian's shared library (no TINYGLTF_IMPLEMENTATION here); stb is not installed
// and tiles carry no images.
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam {
namespace {

constexpr int kArrayBuffer = TINYGLTF_TARGET_ARRAY_BUFFER;

// Appends raw bytes to buffer 0 at a 4-byte aligned offset and returns a new bufferView.
int AddBufferView(tinygltf::Model& model, const void* data, std::size_t size, int byte_stride,
                  int target) {
  std::vector<unsigned char>& buffer = model.buffers[0].data;
  while (buffer.size() % 4 != 0) buffer.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = size;
  view.byteStride = static_cast<std::size_t>(byte_stride);
  view.target = target;
  const auto* bytes = static_cast<const unsigned char*>(data);
  buffer.insert(buffer.end(), bytes, bytes + size);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size() - 1);
}

int AddAccessor(tinygltf::Model& model, int buffer_view, int component_type, int type,
                std::size_t count, bool normalized, std::vector<double> min_values,
                std::vector<double> max_values) {
  tinygltf::Accessor accessor;
  accessor.bufferView = buffer_view;
  accessor.componentType = component_type;
  accessor.type = type;
  accessor.count = count;
  accessor.normalized = normalized;
  accessor.minValues = std::move(min_values);
  accessor.maxValues = std::move(max_values);
  model.accessors.push_back(accessor);
  return static_cast<int>(model.accessors.size() - 1);
}

tinygltf::Model NewModel() {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "GLAM server";
  model.buffers.emplace_back();
  return model;
}

// Positions in glTF y-up, with min/max of the float values.
struct GltfPositions {
  std::vector<float> xyz;
  std::vector<double> min{0, 0, 0};
  std::vector<double> max{0, 0, 0};
};

GltfPositions ToGltf(const std::vector<Eigen::Vector3f>& positions) {
  GltfPositions out;
  out.xyz.reserve(positions.size() * 3);
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const Eigen::Vector3f& p : positions) {
    if (!p.allFinite()) throw InputError("tile geometry has a non-finite coordinate");
    const Eigen::Vector3f g = GltfFromZUp(p);
    out.xyz.insert(out.xyz.end(), {g.x(), g.y(), g.z()});
    lo = lo.cwiseMin(g);
    hi = hi.cwiseMax(g);
  }
  if (!positions.empty()) {
    out.min = {lo.x(), lo.y(), lo.z()};
    out.max = {hi.x(), hi.y(), hi.z()};
  }
  return out;
}

std::vector<Eigen::Vector3f> PositionsOf(const std::vector<ColoredPoint>& points) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(points.size());
  for (const ColoredPoint& p : points) out.push_back(p.position);
  return out;
}

// A mesh with one primitive and the node that places it; mesh and node share the name (tests
// and viewers find "points" / "trajectory" by it).
void AddMeshNode(tinygltf::Model& model, const std::string& name, const tinygltf::Primitive& primitive,
                 std::vector<double> translation = {}, std::vector<double> scale = {}) {
  tinygltf::Mesh mesh;
  mesh.name = name;
  mesh.primitives.push_back(primitive);
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.name = name;
  node.mesh = static_cast<int>(model.meshes.size() - 1);
  node.translation = std::move(translation);
  node.scale = std::move(scale);
  model.nodes.push_back(node);
}

// The trajectory as a LINE_STRIP mesh + node (float positions; a few hundred vertices, not
// worth compressing). Needs 2 or more centres.
void AddTrajectory(tinygltf::Model& model, const std::vector<Eigen::Vector3f>& trajectory) {
  if (trajectory.size() < 2) return;
  const GltfPositions positions = ToGltf(trajectory);
  const int view = AddBufferView(model, positions.xyz.data(), positions.xyz.size() * sizeof(float), 0,
                                 kArrayBuffer);
  const int accessor = AddAccessor(model, view, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                   trajectory.size(), false, positions.min, positions.max);
  tinygltf::Material material;
  material.name = "trajectory";
  material.pbrMetallicRoughness.baseColorFactor = {1.0, 0.35, 0.1, 1.0};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  model.materials.push_back(material);
  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_LINE_STRIP;
  primitive.attributes["POSITION"] = accessor;
  primitive.material = static_cast<int>(model.materials.size() - 1);
  AddMeshNode(model, "trajectory", primitive);
}

void AddPointsNode(tinygltf::Model& model, const tinygltf::Primitive& primitive,
                   std::vector<double> translation = {}, std::vector<double> scale = {}) {
  AddMeshNode(model, "points", primitive, std::move(translation), std::move(scale));
}

std::string Serialize(tinygltf::Model& model) {
  if (!model.nodes.empty()) {
    tinygltf::Scene scene;
    for (std::size_t i = 0; i < model.nodes.size(); ++i) scene.nodes.push_back(static_cast<int>(i));
    model.scenes.push_back(scene);
    model.defaultScene = 0;
  }
  if (model.buffers[0].data.empty()) model.buffers.clear();
  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, out, false, true)) {
    throw EnvironmentError("tinygltf could not serialize a map tile");
  }
  return out.str();
}

void AddColors(std::vector<std::uint8_t>& rgb, const std::vector<ColoredPoint>& points, int stride) {
  rgb.assign(points.size() * static_cast<std::size_t>(stride), 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::memcpy(&rgb[i * static_cast<std::size_t>(stride)], points[i].color.data(), 3);
  }
}

double LargestSide(const std::vector<ColoredPoint>& points) {
  if (points.empty()) return 0;
  Eigen::AlignedBox3f box;
  for (const ColoredPoint& p : points) box.extend(p.position);
  return static_cast<double>(box.sizes().maxCoeff());
}

}  // namespace

Eigen::Vector3f GltfFromZUp(const Eigen::Vector3f& p) { return {p.x(), p.z(), -p.y()}; }
Eigen::Vector3f ZUpFromGltf(const Eigen::Vector3f& p) { return {p.x(), -p.z(), p.y()}; }

Eigen::AlignedBox3d TileBounds(const TileGeometry& geometry) {
  Eigen::AlignedBox3d box;
  for (const ColoredPoint& p : geometry.points) box.extend(p.position.cast<double>());
  for (const Eigen::Vector3f& c : geometry.trajectory) box.extend(c.cast<double>());
  return box;
}

void DracoTileOptions::Check() const {
  CheckInRange("draco position_bits", position_bits, 8, 24);
  CheckInRange("draco encode_speed", encode_speed, 0, 10);
}

double DracoPositionErrorBound(const std::vector<ColoredPoint>& points, int position_bits) {
  return LargestSide(points) / (2.0 * (std::ldexp(1.0, position_bits) - 1.0));
}

double QuantizedPositionErrorBound(const std::vector<ColoredPoint>& points) {
  return LargestSide(points) / (4.0 * 32767.0);
}

std::string EncodeDracoTileGlb(const TileGeometry& geometry, const DracoTileOptions& options) {
  options.Check();
  tinygltf::Model model = NewModel();
  if (!geometry.points.empty()) {
    const std::size_t n = geometry.points.size();
    const GltfPositions positions = ToGltf(PositionsOf(geometry.points));
    std::vector<std::uint8_t> rgb;
    AddColors(rgb, geometry.points, 3);

    draco::PointCloudBuilder builder;
    builder.Start(static_cast<draco::PointIndex::ValueType>(n));
    const int position_att = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    const int color_att = builder.AddAttribute(draco::GeometryAttribute::COLOR, 3, draco::DT_UINT8);
    builder.SetAttributeValuesForAllPoints(position_att, positions.xyz.data(), 0);
    builder.SetAttributeValuesForAllPoints(color_att, rgb.data(), 0);
    std::unique_ptr<draco::PointCloud> cloud = builder.Finalize(false);
    if (!cloud) throw EnvironmentError("Draco could not build the tile's point cloud");

    draco::Encoder encoder;
    encoder.SetSpeedOptions(options.encode_speed, options.encode_speed);
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, options.position_bits);
    draco::EncoderBuffer encoded;
    const draco::Status status = encoder.EncodePointCloudToBuffer(*cloud, &encoded);
    if (!status.ok()) {
      throw EnvironmentError(fmt::format("Draco could not encode a tile: {}", status.error_msg_string()));
    }
    const int view = AddBufferView(model, encoded.data(), encoded.size(), 0, -1);
    const int position_accessor = AddAccessor(model, -1, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n,
                                              false, positions.min, positions.max);
    const int color_accessor =
        AddAccessor(model, -1, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC3, n, true, {}, {});

    tinygltf::Value::Object attributes;
    attributes["POSITION"] = tinygltf::Value(static_cast<int>(cloud->attribute(position_att)->unique_id()));
    attributes["COLOR_0"] = tinygltf::Value(static_cast<int>(cloud->attribute(color_att)->unique_id()));
    tinygltf::Value::Object draco_extension;
    draco_extension["bufferView"] = tinygltf::Value(view);
    draco_extension["attributes"] = tinygltf::Value(attributes);

    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_POINTS;
    primitive.attributes["POSITION"] = position_accessor;
    primitive.attributes["COLOR_0"] = color_accessor;
    primitive.extensions["KHR_draco_mesh_compression"] = tinygltf::Value(draco_extension);
    AddPointsNode(model, primitive);
    model.extensionsUsed.push_back("KHR_draco_mesh_compression");
    model.extensionsRequired.push_back("KHR_draco_mesh_compression");
  }
  AddTrajectory(model, geometry.trajectory);
  return Serialize(model);
}

std::string EncodeQuantizedTileGlb(const TileGeometry& geometry) {
  tinygltf::Model model = NewModel();
  if (!geometry.points.empty()) {
    const std::size_t n = geometry.points.size();
    const GltfPositions positions = ToGltf(PositionsOf(geometry.points));
    // Node transform: p = centre + half * q / 32767 with q in [-32767, 32767] per axis.
    const Eigen::Vector3d lo(positions.min[0], positions.min[1], positions.min[2]);
    const Eigen::Vector3d hi(positions.max[0], positions.max[1], positions.max[2]);
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    double half = 0.5 * (hi - lo).maxCoeff();
    if (!(half > 0)) half = 1.0;  // one point (or all equal): any scale represents it exactly
    // Stride 8: glTF wants every vertex attribute element 4-byte aligned.
    std::vector<std::int16_t> q(n * 4, 0);
    Eigen::Vector3i qmin = Eigen::Vector3i::Constant(32767);
    Eigen::Vector3i qmax = Eigen::Vector3i::Constant(-32767);
    for (std::size_t i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) {
        const double v = (positions.xyz[i * 3 + static_cast<std::size_t>(a)] - centre[a]) / half * 32767.0;
        const int qi = static_cast<int>(std::clamp(std::lround(v), -32767L, 32767L));
        q[i * 4 + static_cast<std::size_t>(a)] = static_cast<std::int16_t>(qi);
        qmin[a] = std::min(qmin[a], qi);
        qmax[a] = std::max(qmax[a], qi);
      }
    }
    std::vector<std::uint8_t> rgb;
    AddColors(rgb, geometry.points, 4);
    const int position_view = AddBufferView(model, q.data(), q.size() * sizeof(std::int16_t), 8, kArrayBuffer);
    const int color_view = AddBufferView(model, rgb.data(), rgb.size(), 4, kArrayBuffer);
    const int position_accessor =
        AddAccessor(model, position_view, TINYGLTF_COMPONENT_TYPE_SHORT, TINYGLTF_TYPE_VEC3, n, true,
                    {double(qmin[0]), double(qmin[1]), double(qmin[2])},
                    {double(qmax[0]), double(qmax[1]), double(qmax[2])});
    const int color_accessor = AddAccessor(model, color_view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                           TINYGLTF_TYPE_VEC3, n, true, {}, {});
    tinygltf::Primitive primitive;
    primitive.mode = TINYGLTF_MODE_POINTS;
    primitive.attributes["POSITION"] = position_accessor;
    primitive.attributes["COLOR_0"] = color_accessor;
    AddPointsNode(model, primitive, {centre.x(), centre.y(), centre.z()}, {half, half, half});
    model.extensionsUsed.push_back("KHR_mesh_quantization");
    model.extensionsRequired.push_back("KHR_mesh_quantization");
  }
  AddTrajectory(model, geometry.trajectory);
  return Serialize(model);
}

}  // namespace glam
