// kfx._core: `reproduce`: each paper's published numbers beside kfx's, as a list of dicts
// (src/reproduce/include/kfx/reproduce.hpp).
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kfx/reproduce.hpp"
#include "long_call.hpp"

namespace kfx::python {
namespace {

py::dict ItemToDict(const std::string& paper, const ReproduceItem& it) {
  py::dict d;
  d["paper"] = paper;
  d["key"] = it.key;
  d["description"] = it.description;
  d["published"] = it.published ? py::object(py::float_(*it.published)) : py::object(py::none());
  d["value"] = it.value;
  const auto rel = it.rel_diff();
  d["rel_diff"] = rel ? py::object(py::float_(*rel)) : py::object(py::none());
  d["tolerance"] = it.tolerance;
  d["status"] = it.status();
  d["note"] = it.note;
  return d;
}

}  // namespace

void BindReproduce(py::module_& m) {
  m.def("paper_ids", &PaperIds, "The ids accepted by reproduce(), in paper order.");
  m.def(
      "reproduce",
      [](const std::string& paper, bool quick, const std::string& out_dir, const py::object& progress) {
        std::vector<std::string> ids = paper == "all" ? PaperIds() : std::vector<std::string>{paper};
        py::list items;
        for (const auto& id : ids) {
          ReproduceOptions o;
          o.quick = quick;
          if (!out_dir.empty()) o.out_dir = paper == "all" ? out_dir + "/" + id : out_dir;
          LongCall call(progress);
          o.progress = call.callback();
          const PaperReport r = call.Run([&] { return Reproduce(id, o); });
          for (const auto& it : r.items) items.append(ItemToDict(id, it));
        }
        return items;
      },
      py::arg("paper"), py::arg("quick") = false, py::arg("out_dir") = "", py::arg("progress") = py::none(),
      "A paper's published numbers beside kfx's, as a list of dicts (keys: paper, key, description, published, "
      "value, rel_diff, tolerance, status, note). paper: one of paper_ids() or 'all'. out_dir: where CSV data "
      "for figures goes (kfx.plots.render(out_dir) draws them). progress: None or progress(done, total) for "
      "each paper in turn, at most every 0.05 s; Ctrl-C stops the run with KeyboardInterrupt. Raises kfx.Error "
      "if paper is not one of paper_ids() or 'all', or if out_dir cannot be written.");
}

}  // namespace kfx::python
