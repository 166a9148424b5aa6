#include "vog/sonar/aris_availability.hpp"

#include "aris_protobuf.hpp"
#include "vog/sonar/aris_availability.pb.h"

namespace vog::sonar {

using detail::parsed;
using detail::serialized;

std::vector<std::uint8_t> encodeArisAvailability(const ArisAvailability& a) {
  aris::Availability msg;
  msg.set_serialnumber(a.serial_number);
  msg.set_systemtype(static_cast<aris::Availability::SystemType>(a.system_type));
  msg.mutable_softwareversion()->set_major(a.version_major);
  msg.mutable_softwareversion()->set_minor(a.version_minor);
  msg.mutable_softwareversion()->set_buildnumber(a.version_build);
  msg.set_connectionstate(a.busy ? aris::Availability::BUSY : aris::Availability::AVAILABLE);
  for (const std::string& c : a.capabilities) msg.mutable_capabilities()->add_enabled(c);
  return serialized(msg);
}

Result<ArisAvailability> decodeArisAvailability(std::span<const std::uint8_t> datagram) {
  aris::Availability msg;
  if (!parsed(msg, datagram)) {
    return Error{"ARIS beacon: " + std::to_string(datagram.size()) + " bytes are not an Availability message"};
  }
  // proto3 keeps enum values it does not know: they are the sender's, not ours to guess.
  const int type = msg.systemtype();
  if (type < 0 || type > static_cast<int>(ArisSystemType::k1200)) {
    return Error{"ARIS beacon: systemType " + std::to_string(type) + " is not 0 (1800), 1 (3000) or 2 (1200)"};
  }
  const int state = msg.connectionstate();
  if (state != aris::Availability::AVAILABLE && state != aris::Availability::BUSY) {
    return Error{"ARIS beacon: connectionState " + std::to_string(state) + " is not 0 (available) or 1 (busy)"};
  }
  ArisAvailability a;
  a.serial_number = msg.serialnumber();
  a.system_type = static_cast<ArisSystemType>(type);
  a.version_major = msg.softwareversion().major();
  a.version_minor = msg.softwareversion().minor();
  a.version_build = msg.softwareversion().buildnumber();
  a.busy = state == aris::Availability::BUSY;
  a.capabilities.assign(msg.capabilities().enabled().begin(), msg.capabilities().enabled().end());
  return a;
}

}  // namespace vog::sonar
