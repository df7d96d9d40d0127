#include "tests/export/glb_test_util.h"

#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include <draco/compression/decode.h>
#include <gtest/gtest.h>

namespace glam::testing {
namespace {

const unsigned char* AccessorData(const tinygltf::Model& model, const tinygltf::Accessor& accessor,
                                  std::size_t* stride, std::size_t element_size) {
  const tinygltf::BufferView& view = model.bufferViews.at(static_cast<std::size_t>(accessor.bufferView));
  *stride = view.byteStride != 0 ? view.byteStride : element_size;
  const tinygltf::Buffer& buffer = model.buffers.at(static_cast<std::size_t>(view.buffer));
  EXPECT_LE(view.byteOffset + accessor.byteOffset + (accessor.count - 1) * *stride + element_size,
            buffer.data.size());
  return buffer.data.data() + view.byteOffset + accessor.byteOffset;
}

}  // namespace

tinygltf::Model ParseGlb(const std::string& bytes) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string error, warning;
  const bool ok = loader.LoadBinaryFromMemory(&model, &error, &warning,
                                              reinterpret_cast<const unsigned char*>(bytes.data()),
                                              static_cast<unsigned int>(bytes.size()));
  EXPECT_TRUE(ok) << error;
  EXPECT_TRUE(error.empty()) << error;
  return ok ? model : tinygltf::Model();
}

int FindNode(const tinygltf::Model& model, const std::string& mesh_name) {
  for (std::size_t i = 0; i < model.nodes.size(); ++i) {
    const int mesh = model.nodes[i].mesh;
    if (mesh >= 0 && model.meshes[static_cast<std::size_t>(mesh)].name == mesh_name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<ColoredPoint> DecodeDracoPoints(const tinygltf::Model& model) {
  const int node = FindNode(model, "points");
  if (node < 0) {
    ADD_FAILURE() << "no points node";
    return {};
  }
  const tinygltf::Primitive& primitive =
      model.meshes[static_cast<std::size_t>(model.nodes[static_cast<std::size_t>(node)].mesh)].primitives.at(0);
  EXPECT_EQ(primitive.mode, TINYGLTF_MODE_POINTS);
  const auto ext = primitive.extensions.find("KHR_draco_mesh_compression");
  if (ext == primitive.extensions.end()) {
    ADD_FAILURE() << "points primitive is not Draco-compressed";
    return {};
  }
  const tinygltf::Value& draco_ext = ext->second;
  const int view_index = draco_ext.Get("bufferView").GetNumberAsInt();
  const tinygltf::BufferView& view = model.bufferViews.at(static_cast<std::size_t>(view_index));
  const tinygltf::Buffer& buffer = model.buffers.at(static_cast<std::size_t>(view.buffer));
  draco::DecoderBuffer input;
  input.Init(reinterpret_cast<const char*>(buffer.data.data() + view.byteOffset), view.byteLength);
  draco::Decoder decoder;
  auto decoded = decoder.DecodePointCloudFromBuffer(&input);
  if (!decoded.ok()) {
    ADD_FAILURE() << "Draco decode failed: " << decoded.status().error_msg_string();
    return {};
  }
  const std::unique_ptr<draco::PointCloud> cloud = std::move(decoded).value();
  const auto unique_id = [&](const char* name) {
    return static_cast<std::uint32_t>(draco_ext.Get("attributes").Get(name).GetNumberAsInt());
  };
  const draco::PointAttribute* position = cloud->GetAttributeByUniqueId(unique_id("POSITION"));
  const draco::PointAttribute* color = cloud->GetAttributeByUniqueId(unique_id("COLOR_0"));
  if (position == nullptr || color == nullptr) {
    ADD_FAILURE() << "Draco attributes missing";
    return {};
  }
  const tinygltf::Accessor& position_accessor =
      model.accessors.at(static_cast<std::size_t>(primitive.attributes.at("POSITION")));
  EXPECT_EQ(position_accessor.count, cloud->num_points());
  std::vector<ColoredPoint> points(cloud->num_points());
  for (draco::PointIndex i(0); i < cloud->num_points(); ++i) {
    std::array<float, 3> p{};
    std::array<std::uint8_t, 3> c{};
    EXPECT_TRUE((position->ConvertValue<float, 3>(position->mapped_index(i), p.data())));
    EXPECT_TRUE((color->ConvertValue<std::uint8_t, 3>(color->mapped_index(i), c.data())));
    points[i.value()].position = ZUpFromGltf(Eigen::Vector3f(p[0], p[1], p[2]));
    points[i.value()].color = c;
  }
  return points;
}

std::vector<ColoredPoint> DequantizePoints(const tinygltf::Model& model) {
  const int node_index = FindNode(model, "points");
  if (node_index < 0) {
    ADD_FAILURE() << "no points node";
    return {};
  }
  const tinygltf::Node& node = model.nodes[static_cast<std::size_t>(node_index)];
  const tinygltf::Primitive& primitive = model.meshes[static_cast<std::size_t>(node.mesh)].primitives.at(0);
  EXPECT_EQ(primitive.mode, TINYGLTF_MODE_POINTS);
  const tinygltf::Accessor& pa = model.accessors.at(static_cast<std::size_t>(primitive.attributes.at("POSITION")));
  const tinygltf::Accessor& ca = model.accessors.at(static_cast<std::size_t>(primitive.attributes.at("COLOR_0")));
  EXPECT_EQ(pa.componentType, TINYGLTF_COMPONENT_TYPE_SHORT);
  EXPECT_TRUE(pa.normalized);
  EXPECT_EQ(ca.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE);
  EXPECT_TRUE(ca.normalized);
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();
  if (node.translation.size() == 3) translation = Eigen::Vector3d(node.translation.data());
  if (node.scale.size() == 3) scale = Eigen::Vector3d(node.scale.data());
  std::size_t pstride = 0, cstride = 0;
  const unsigned char* pdata = AccessorData(model, pa, &pstride, 6);
  const unsigned char* cdata = AccessorData(model, ca, &cstride, 3);
  std::vector<ColoredPoint> points(pa.count);
  for (std::size_t i = 0; i < pa.count; ++i) {
    std::int16_t q[3];
    std::memcpy(q, pdata + i * pstride, sizeof(q));
    Eigen::Vector3d g;
    for (int a = 0; a < 3; ++a) g[a] = std::max(q[a] / 32767.0, -1.0) * scale[a] + translation[a];
    points[i].position = ZUpFromGltf(g.cast<float>());
    std::memcpy(points[i].color.data(), cdata + i * cstride, 3);
  }
  return points;
}

std::vector<Eigen::Vector3f> TrajectoryPoints(const tinygltf::Model& model) {
  const int node = FindNode(model, "trajectory");
  if (node < 0) return {};
  const tinygltf::Primitive& primitive =
      model.meshes[static_cast<std::size_t>(model.nodes[static_cast<std::size_t>(node)].mesh)].primitives.at(0);
  EXPECT_EQ(primitive.mode, TINYGLTF_MODE_LINE_STRIP);
  const tinygltf::Accessor& accessor =
      model.accessors.at(static_cast<std::size_t>(primitive.attributes.at("POSITION")));
  EXPECT_EQ(accessor.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
  std::size_t stride = 0;
  const unsigned char* data = AccessorData(model, accessor, &stride, 12);
  std::vector<Eigen::Vector3f> out(accessor.count);
  for (std::size_t i = 0; i < accessor.count; ++i) {
    Eigen::Vector3f g;
    std::memcpy(g.data(), data + i * stride, 12);
    out[i] = ZUpFromGltf(g);
  }
  return out;
}

nlohmann::json ValidateGltf(const std::filesystem::path& file) {
  const std::filesystem::path tool = std::filesystem::path(GLAM_SOURCE_DIR) / "tools" / "gltf-validator";
  if (!std::filesystem::exists(tool / "node_modules" / "gltf-validator")) {
    ADD_FAILURE() << "the glTF Validator is not installed: run scripts/setup-node.sh (make deps)";
    return {};
  }
  const std::string command = "node '" + (tool / "validate.mjs").string() + "' '" + file.string() + "'";
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) {
    ADD_FAILURE() << "cannot run " << command;
    return {};
  }
  std::string output;
  char chunk[4096];
  std::size_t n = 0;
  while ((n = std::fread(chunk, 1, sizeof(chunk), pipe)) > 0) output.append(chunk, n);
  const int status = ::pclose(pipe);
  const nlohmann::json report = nlohmann::json::parse(output, nullptr, false);
  if (report.is_discarded() || !report.contains("issues")) {
    ADD_FAILURE() << command << " (status " << status << ") printed no report:\n" << output;
    return {};
  }
  return report;
}

std::string ReadBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Eigen::Matrix4d FromColumnMajor(const nlohmann::json& a) {
  EXPECT_EQ(a.size(), 16u);
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  for (std::size_t col = 0; col < 4 && a.size() == 16; ++col) {
    for (std::size_t row = 0; row < 4; ++row) m(row, col) = a[col * 4 + row].get<double>();
  }
  return m;
}

std::vector<ColoredPoint> ChildTileWorldPoints(const std::filesystem::path& out_dir, const nlohmann::json& child) {
  const std::string uri = child.at("content").at("uri").get<std::string>();  // tiles/<id>.glb?v=<run>
  const Eigen::Matrix4d world_from_submap = FromColumnMajor(child.at("transform"));
  std::vector<ColoredPoint> points = DecodeDracoPoints(ParseGlb(ReadBytes(out_dir / uri.substr(0, uri.find('?')))));
  for (ColoredPoint& p : points) {
    p.position = (world_from_submap * p.position.cast<double>().homogeneous()).head<3>().cast<float>();
  }
  return points;
}

}  // namespace glam::testing
