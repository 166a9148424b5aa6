#include "vog/vehicle/endpoints.hpp"

#include "vog/core/atomic_file.hpp"
#include "vog/yaml/config_reader.hpp"

#include <cmath>
#include <cstring>
#include <string>

#include <yaml-cpp/yaml.h>

namespace vog::vehicle {

const char* toString(SonarKind kind) {
  switch (kind) {
    case SonarKind::kFragments: return "fragments";
    case SonarKind::kAris: return "aris";
  }
  return "?";
}

Result<SonarKind> parseSonarKind(std::string_view text) {
  if (text == "fragments") return SonarKind::kFragments;
  if (text == "aris") return SonarKind::kAris;
  return Error{"sonar kind '" + std::string(text) + "' unknown (expected fragments or aris)"};
}

Status writeEndpointsFile(const std::filesystem::path& file, const VehicleEndpoints& e) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "format_version" << YAML::Value << e.format_version;
  out << YAML::Key << "scene" << YAML::Value << YAML::BeginMap << YAML::Key << "file" << YAML::Value << e.scene_file
      << YAML::Key << "name" << YAML::Value << e.scene_name << YAML::EndMap;
  out << YAML::Key << "seed" << YAML::Value << e.seed;
  out << YAML::Key << "pid" << YAML::Value << e.pid;
  out << YAML::Key << "time" << YAML::Value << YAML::BeginMap << YAML::Key << "speedup" << YAML::Value << e.speedup
      << YAML::Key << "steady_ns_at_sim_zero" << YAML::Value << e.steady_ns_at_sim_zero << YAML::Key << "epoch_unix_ns"
      << YAML::Value << e.epoch_unix_ns << YAML::EndMap;
  out << YAML::Key << "origin" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "latitude_deg"
      << YAML::Value << e.origin_latitude_deg << YAML::Key << "longitude_deg" << YAML::Value << e.origin_longitude_deg
      << YAML::EndMap;
  out << YAML::Key << "start" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "xyz" << YAML::Value
      << YAML::Flow << YAML::BeginSeq << e.start_xyz_world.x() << e.start_xyz_world.y() << e.start_xyz_world.z()
      << YAML::EndSeq << YAML::Key << "yaw_deg" << YAML::Value << e.start_yaw_deg << YAML::EndMap;
  out << YAML::Key << "dvl" << YAML::Value << YAML::BeginMap << YAML::Key << "format" << YAML::Value << "pd0"
      << YAML::Key << "device" << YAML::Value << e.dvl_device << YAML::Key << "baud" << YAML::Value << e.dvl_baud
      << YAML::Key << "mount_yaw_deg" << YAML::Value << e.dvl_mount_yaw_deg << YAML::EndMap;
  out << YAML::Key << "depth" << YAML::Value << YAML::BeginMap << YAML::Key << "device" << YAML::Value << e.depth_device
      << YAML::Key << "baud" << YAML::Value << e.depth_baud << YAML::Key << "units_code" << YAML::Value
      << e.depth_units_code << YAML::Key << "latitude_deg" << YAML::Value << e.depth_latitude_deg << YAML::Key
      << "atmospheric_pressure_pa" << YAML::Value << e.depth_atmospheric_pressure_pa << YAML::Key
      << "reading_is_absolute" << YAML::Value << e.depth_reading_is_absolute << YAML::EndMap;
  out << YAML::Key << "imu" << YAML::Value << YAML::BeginMap << YAML::Key << "unix_seqpacket" << YAML::Value
      << e.imu_unix_seqpacket << YAML::Key << "base_id" << YAML::Value << e.imu_base_id << YAML::EndMap;
  out << YAML::Key << "sonar" << YAML::Value << YAML::BeginMap << YAML::Key << "kind" << YAML::Value
      << toString(e.sonar_kind) << YAML::Key << "address" << YAML::Value << e.sonar_address;
  if (e.sonar_kind == SonarKind::kAris) {
    out << YAML::Key << "command_port" << YAML::Value << e.sonar_command_port << YAML::Key << "beacon_port"
        << YAML::Value << e.sonar_beacon_port << YAML::Key << "serial_number" << YAML::Value << e.sonar_serial_number;
  } else {
    out << YAML::Key << "port" << YAML::Value << e.sonar_port;
  }
  out << YAML::EndMap;
  out << YAML::Key << "backseat" << YAML::Value << YAML::BeginMap << YAML::Key << "address" << YAML::Value
      << e.backseat_address << YAML::Key << "port" << YAML::Value << e.backseat_port << YAML::EndMap;
  out << YAML::Key << "control" << YAML::Value << YAML::BeginMap << YAML::Key << "socket" << YAML::Value
      << e.control_socket << YAML::EndMap;
  out << YAML::EndMap;
  if (!out.good()) return Error{"endpoints file: YAML emitter: " + out.GetLastError()};
  std::string text = "# vogsim vehicle endpoints (sim/README.md)\n";
  text += out.c_str();
  text += "\n";

  if (Status st = writeFileAtomically(file, text); !st.ok())
    return Error{"endpoints file " + file.string() + ": " + st.error().message};
  return Status::success();
}

Result<VehicleEndpoints> readEndpointsFile(const std::filesystem::path& file) {
  auto text = yaml::readText(file, "endpoints file");
  if (!text) return text.error();
  auto document = yaml::parseDocument(text.value(), file.string());
  if (!document) return document.error();
  const YAML::Node root = document.value();
  VehicleEndpoints e;
  std::string missing;
  auto get = [&](const char* section, const char* key) -> YAML::Node {
    const YAML::Node s = section[0] != '\0' ? root[section] : root;
    const YAML::Node n = s ? s[key] : YAML::Node();
    if ((!n || n.IsNull()) && missing.empty()) missing = section[0] != '\0' ? std::string(section) + "." + key : key;
    return n;
  };
  try {
    if (!root.IsMap()) return Error{file.string() + ": not a YAML map"};
    auto num = [&](const char* section, const char* key, auto& out) {
      const YAML::Node n = get(section, key);
      if (n && !n.IsNull()) out = n.as<std::remove_reference_t<decltype(out)>>();
    };
    num("", "format_version", e.format_version);
    if (e.format_version != 1)
      return Error{file.string() + ": format_version " + std::to_string(e.format_version) + " is not supported (1)"};
    num("scene", "file", e.scene_file);
    num("scene", "name", e.scene_name);
    num("", "seed", e.seed);
    num("", "pid", e.pid);
    num("time", "speedup", e.speedup);
    num("time", "steady_ns_at_sim_zero", e.steady_ns_at_sim_zero);
    num("time", "epoch_unix_ns", e.epoch_unix_ns);
    num("origin", "latitude_deg", e.origin_latitude_deg);
    num("origin", "longitude_deg", e.origin_longitude_deg);
    const YAML::Node xyz = get("start", "xyz");
    if (xyz && (!xyz.IsSequence() || xyz.size() != 3)) return Error{file.string() + ": start.xyz must be [x, y, z]"};
    if (xyz) e.start_xyz_world = Eigen::Vector3d(xyz[0].as<double>(), xyz[1].as<double>(), xyz[2].as<double>());
    num("start", "yaw_deg", e.start_yaw_deg);
    num("dvl", "device", e.dvl_device);
    num("dvl", "baud", e.dvl_baud);
    num("dvl", "mount_yaw_deg", e.dvl_mount_yaw_deg);
    num("depth", "device", e.depth_device);
    num("depth", "baud", e.depth_baud);
    num("depth", "units_code", e.depth_units_code);
    num("depth", "latitude_deg", e.depth_latitude_deg);
    num("depth", "atmospheric_pressure_pa", e.depth_atmospheric_pressure_pa);
    num("depth", "reading_is_absolute", e.depth_reading_is_absolute);
    num("imu", "unix_seqpacket", e.imu_unix_seqpacket);
    num("imu", "base_id", e.imu_base_id);
    const YAML::Node sonar = root["sonar"];
    if (sonar && sonar["kind"] && !sonar["kind"].IsNull()) {
      auto kind = parseSonarKind(sonar["kind"].as<std::string>());
      if (!kind) return Error{file.string() + ": sonar.kind: " + kind.error().message};
      e.sonar_kind = *kind;
    }
    num("sonar", "address", e.sonar_address);
    if (e.sonar_kind == SonarKind::kAris) {
      num("sonar", "command_port", e.sonar_command_port);
      num("sonar", "beacon_port", e.sonar_beacon_port);
      num("sonar", "serial_number", e.sonar_serial_number);
    } else {
      num("sonar", "port", e.sonar_port);
    }
    num("backseat", "address", e.backseat_address);
    num("backseat", "port", e.backseat_port);
    const YAML::Node control = root["control"];
    if (control && control["socket"] && !control["socket"].IsNull())
      e.control_socket = control["socket"].as<std::string>();
  } catch (const YAML::Exception& ex) {
    return Error{file.string() + ": " + ex.what()};
  }
  if (!missing.empty()) return Error{file.string() + ": missing key " + missing};
  if (!(e.speedup > 0.0) || !std::isfinite(e.speedup))
    return Error{file.string() + ": time.speedup must be > 0, got " + std::to_string(e.speedup)};
  return e;
}

std::int64_t simStampFromSteady(const VehicleEndpoints& endpoints, std::int64_t steady_ns) {
  return static_cast<std::int64_t>(
      std::llround(static_cast<double>(steady_ns - endpoints.steady_ns_at_sim_zero) * endpoints.speedup));
}

}  // namespace vog::vehicle
