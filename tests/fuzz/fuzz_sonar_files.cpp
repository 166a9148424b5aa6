// DDF v3/v4 and ARIS readers: arbitrary files give a recording or an error, never a crash, and
// every frame has as many samples as its geometry says.
#include "fuzz_check.hpp"
#include "vog/sonar/sonar_files.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  vog::sonar::SonarFileLimits limits;
  limits.max_samples = 1024;
  limits.max_frames = 64;
  for (const bool aris : {false, true}) {
    const auto rec =
        aris ? vog::sonar::decodeArisFile({data, size}, limits) : vog::sonar::decodeDdfFile({data, size}, limits);
    if (!rec.ok()) continue;
    for (const auto& f : rec->frames) {
      VOG_FUZZ_CHECK(f.samples.size() == static_cast<std::size_t>(f.n_beams) * static_cast<std::size_t>(f.n_samples));
    }
  }
  return 0;
}
