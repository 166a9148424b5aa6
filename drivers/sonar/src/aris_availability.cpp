#include "vog/sonar/aris_availability.hpp"

#include "aris_protobuf.hpp"
#include "vog/sonar/aris_availability.pb.h"

namespace vog::sonar {

std::vector<std::uint8_t> encodeArisAvailability(const ArisAvailability& availability) {
  aris::Availability msg;
  msg.set_serialnumber(availability.serial_number);
  msg.set_systemtype(static_cast<aris::Availability_SystemType>(availability.system_type));
  aris::Availability_SoftwareVersion* version = msg.mutable_softwareversion();
  version->set_major(availability.version_major);
  version->set_minor(availability.version_minor);
  version->set_buildnumber(availability.version_build);
  msg.set_connectionstate(availability.busy ? aris::Availability_ConnectionState_BUSY
                                            : aris::Availability_ConnectionState_AVAILABLE);
  aris::Availability_Capabilities* capabilities = msg.mutable_capabilities();
  for (const std::string& c : availability.capabilities) capabilities->add_enabled(c);
  return detail::serialized(msg);
}

Result<ArisAvailability> decodeArisAvailability(std::span<const std::uint8_t> datagram) {
  aris::Availability msg;
  if (!detail::parsed(msg, datagram)) {
    return Error{"ARIS Availability: " + std::to_string(datagram.size()) + " bytes do not decode"};
  }
  // proto3 enums are open: an undefined value parses and is kept as its number.
  if (!aris::Availability_SystemType_IsValid(msg.systemtype())) {
    return Error{"ARIS Availability: systemType " + std::to_string(msg.systemtype()) +
                 " unknown (ARIS_1800=0, ARIS_3000=1, ARIS_1200=2)"};
  }
  if (!aris::Availability_ConnectionState_IsValid(msg.connectionstate())) {
    return Error{"ARIS Availability: connectionState " + std::to_string(msg.connectionstate()) +
                 " unknown (AVAILABLE=0, BUSY=1)"};
  }
  ArisAvailability out;
  out.serial_number = msg.serialnumber();
  out.system_type = static_cast<ArisSystemType>(msg.systemtype());
  out.version_major = msg.softwareversion().major();
  out.version_minor = msg.softwareversion().minor();
  out.version_build = msg.softwareversion().buildnumber();
  out.busy = msg.connectionstate() == aris::Availability_ConnectionState_BUSY;
  out.capabilities.assign(msg.capabilities().enabled().begin(), msg.capabilities().enabled().end());
  return out;
}

}  // namespace vog::sonar
