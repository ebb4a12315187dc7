#include "nova/model/model_config.hpp"

#include <sstream>

namespace nova {

std::string network_fingerprint(const ModelConfig& c) {
  std::ostringstream s;
  s << "depth=" << c.field.depth << " width=" << c.field.width << " skip=" << c.field.skip
    << " pos-freqs=" << c.field.pos_freqs << " dir-freqs=" << c.field.dir_freqs
    << " view-dirs=" << c.field.view_dirs;
  if (c.field.encoding == Encoding::HashGrid)  // frequency runs keep their earlier fingerprint
    s << " encoding=hashgrid hash-levels=" << c.field.hash.levels << " hash-features=" << c.field.hash.features
      << " hash-log2-size=" << c.field.hash.log2_size;
  return s.str();
}

}  // namespace nova
