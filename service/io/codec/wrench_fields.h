// The generated coopdyn::wrench_t's fields in the order of a WrenchData row [mx my mz fx fy fz]
// (codec.cc encodes output_t with it, convert.cc decodes it). Private to service/io.
#pragma once

#include "coopdyn/wrench_t.hpp"

namespace coopdyn::io {

constexpr double coopdyn::wrench_t::*kWrenchComponent[6] = {&coopdyn::wrench_t::mx, &coopdyn::wrench_t::my,
                                                            &coopdyn::wrench_t::mz, &coopdyn::wrench_t::fx,
                                                            &coopdyn::wrench_t::fy, &coopdyn::wrench_t::fz};

}  // namespace coopdyn::io
