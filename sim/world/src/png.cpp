// vogsim's PNG entry point: the encoder itself is vog::codec's (drivers/codec/src/png.cpp).

#include "vog/sim/render.hpp"

#include <utility>

namespace vog::sim {

std::string encodePng(const RgbImage& image) {
  auto png = codec::toPng(image);
  return png ? std::move(*png) : std::string();
}

}  // namespace vog::sim
