// has_NAME<M>: whether a generated output_t layout M (output_t, output_v3_t, ...) has the field NAME,
// one trait per field of output_fields.def. The upgrader (convert.cc) and its test use them.
#pragma once

#include <type_traits>

namespace coopdyn::io {

#define COOPDYN_OUTPUT_FIELD(name, type, size, since, absent, on_error, csv, doc) \
  template <class M, class = void>                                               \
  struct has_##name : std::false_type {};                                        \
  template <class M>                                                             \
  struct has_##name<M, std::void_t<decltype(&M::name)>> : std::true_type {};
#include "service/io/codec/output_fields.def"

}  // namespace coopdyn::io
