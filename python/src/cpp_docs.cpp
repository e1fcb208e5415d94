// The C++ doc comments as Python docstrings (issue 21): after every Bind function has run, appends to
// the docstring of each function, class, method and property of kfx._core the `///` comment of the
// C++ declaration it wraps (the table generated at build time by python/gen_cpp_docs.py from
// include/kfx/*.hpp), so that the two cannot drift. A Python name finds its declaration by name,
// ignoring case and underscores (solve_filter_dare -> SolveFilterDare, DareSolution.P_pred ->
// DareSolution::P_pred), or through kRenamed where the names differ.
#include <pybind11/pybind11.h>

#include <cstdlib>
#include <cstring>
#include <map>
#include <string>

#include "bindings.hpp"

namespace kfx::python {
namespace {

struct CppDoc {
  const char* key;
  const char* header;
  const char* text;
};

const CppDoc kCppDocs[] = {
#include <kfx_cpp_docs.inc>  // generated in the build tree (python/CMakeLists.txt), hence <>
};

// Python name -> C++ name where they differ beyond case and underscores.
const std::map<std::string, std::string> kRenamed = {
    {"kalman_schedule", "ComputeKalmanSchedule"}, {"sampled_model_at", "SampledModel"},
    {"parse_method", "ParseMethodSpec"},          {"spring_mass_chain", "BuildSpringMassChain"},
    {"damped_wave", "BuildDampedWave"},
};

std::string Normalized(const std::string& name) {
  std::string out;
  for (char c : name)
    if (c != '_') out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

const std::map<std::string, const CppDoc*>& Table() {
  static const std::map<std::string, const CppDoc*> table = [] {
    std::map<std::string, const CppDoc*> t;
    for (const CppDoc& d : kCppDocs) t.emplace(Normalized(d.key), &d);
    return t;
  }();
  return table;
}

const CppDoc* Find(const std::string& python_name, const std::string& scope = "") {
  auto renamed = kRenamed.find(python_name);
  std::string key = renamed != kRenamed.end() ? renamed->second : python_name;
  if (!scope.empty()) key = scope + "::" + key;
  auto it = Table().find(Normalized(key));
  return it == Table().end() ? nullptr : it->second;
}

std::string Section(const CppDoc& d) {
  return std::string("\n\nC++ (") + d.header + ", " + d.key + "):\n" + d.text + "\n";
}

// A pybind11 function keeps its docstring in the PyMethodDef it allocated (ml_doc, malloc'd, freed
// by pybind11 with std::free): replace it by a longer malloc'd copy. Other callables are left alone.
bool AppendToFunction(py::handle callable, const std::string& extra) {
  py::handle f = py::detail::get_function(callable);
  if (!f || !PyCFunction_Check(f.ptr())) return false;
  py::handle self = PyCFunction_GET_SELF(f.ptr());
  if (!self || !py::isinstance<py::capsule>(self) ||
      !py::detail::is_function_record_capsule(py::reinterpret_borrow<py::capsule>(self)))
    return false;
  PyMethodDef* def = reinterpret_cast<PyCFunctionObject*>(f.ptr())->m_ml;
  std::string doc = def->ml_doc ? def->ml_doc : "";
  while (!doc.empty() && doc.back() == '\n') doc.pop_back();
  doc += extra;
  char* old = const_cast<char*>(def->ml_doc);
  def->ml_doc = strdup(doc.c_str());
  std::free(old);
  return true;
}

void AppendToAttribute(py::handle owner, const std::string& extra) {
  py::object doc = py::getattr(owner, "__doc__", py::none());
  std::string text = doc.is_none() ? "" : doc.cast<std::string>();
  while (!text.empty() && text.back() == '\n') text.pop_back();
  py::setattr(owner, "__doc__", py::str(text + (text.empty() ? extra.substr(2) : extra)));
}

void AttachToClass(py::handle cls, const std::string& name) {
  if (const CppDoc* d = Find(name)) AppendToAttribute(cls, Section(*d));
  py::handle property = reinterpret_cast<PyObject*>(&PyProperty_Type);
  py::dict members = cls.attr("__dict__");
  for (auto item : members) {
    std::string member = py::str(item.first);
    if (member.empty() || member[0] == '_') continue;
    py::handle value = item.second;
    const CppDoc* d = Find(member, name);
    // A method bound from a free function (CoupledSystem.to_dense_model -> ToDenseModel).
    if (!d && !py::isinstance(value, property)) d = Find(member);
    if (!d) continue;
    if (py::isinstance(value, property)) {
      AppendToAttribute(value, Section(*d));
    } else {
      AppendToFunction(value, Section(*d));
    }
  }
}

}  // namespace

void AttachCppDocs(py::module_& m) {
  py::dict names = m.attr("__dict__");
  for (auto item : names) {
    std::string name = py::str(item.first);
    if (name.empty() || name[0] == '_') continue;
    if (PyType_Check(item.second.ptr())) {
      AttachToClass(item.second, name);
    } else if (const CppDoc* d = Find(name)) {
      AppendToFunction(item.second, Section(*d));
    }
  }
}

}  // namespace kfx::python
