#include "fringe/util/format.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace fringe::util {

std::string Fixed(double v, int digits) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}

nlohmann::json FigureOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

}  // namespace fringe::util
