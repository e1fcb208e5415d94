// kfx::Summary: the one outcome shape of solvers and long computations (include/kfx/summary.hpp).
#include "kfx/summary.hpp"

#include "kfx/error.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace kfx {

const char* ToString(Termination termination) {
  switch (termination) {
    case Termination::kConverged:
      return "converged";
    case Termination::kNotConverged:
      return "not_converged";
    case Termination::kNotStabilizing:
      return "not_stabilizing";
    case Termination::kNotDetectable:
      return "not_detectable";
    case Termination::kNotStabilizable:
      return "not_stabilizable";
    case Termination::kUnstable:
      return "unstable";
    case Termination::kSingular:
      return "singular";
    case Termination::kLostDefiniteness:
      return "lost_definiteness";
    case Termination::kUndecided:
      return "undecided";
    case Termination::kFailed:
      return "failed";
  }
  return "unknown";
}

std::string FormatNumber(double v, int precision) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", precision, v);
  return buf;
}

void Summary::SetDetail(const std::string& key, std::string value) {
  for (auto& d : details) {
    if (d.first == key) {
      d.second = std::move(value);
      return;
    }
  }
  details.emplace_back(key, std::move(value));
}

std::string Summary::Detail(const std::string& key) const {
  for (const auto& d : details) {
    if (d.first == key) return d.second;
  }
  return "";
}

std::string Summary::BriefReport() const {
  std::ostringstream os;
  os << (computation.empty() ? "computation" : computation) << ": " << ToString(termination);
  if (!method.empty()) os << " by " << method;
  if (iterations > 0) os << ", " << iterations << (iterations == 1 ? " iteration" : " iterations");
  if (!std::isnan(relative_residual)) os << ", relative residual " << FormatNumber(relative_residual);
  if (!std::isnan(relative_change)) os << ", last relative change " << FormatNumber(relative_change);
  os << ", " << FormatNumber(seconds) << " s";
  return os.str();
}

std::string Summary::FullReport() const {
  std::ostringstream os;
  os << "kfx " << (computation.empty() ? "computation" : computation) << " report\n";
  auto row = [&os](const std::string& key, const std::string& value) {
    char line[64];
    std::snprintf(line, sizeof(line), "  %-28s ", key.c_str());
    os << line << value << "\n";
  };
  row("termination", ToString(termination));
  row("method", method.empty() ? "-" : method);
  row("iterations", std::to_string(iterations));
  row("relative residual", std::isnan(relative_residual) ? "-" : FormatNumber(relative_residual));
  row("last relative change", std::isnan(relative_change) ? "-" : FormatNumber(relative_change));
  row("time [s]", FormatNumber(seconds));
  for (const auto& d : details) row(d.first, d.second);
  row("message", message.empty() ? "-" : message);
  return os.str();
}

void Summary::RequireOk() const {
  if (!ok()) throw NumericalError(BriefReport() + (message.empty() ? "" : ": " + message));
}

void AdoptOutcome(const Summary& inner, Summary* outer) {
  outer->termination = inner.termination;
  const std::string what = inner.computation.empty() ? "inner computation" : inner.computation;
  outer->message = what + ": " + (inner.message.empty() ? ToString(inner.termination) : inner.message);
}

}  // namespace kfx
