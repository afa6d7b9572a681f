// _rtu's queries beyond closest hit (python/README.md): neighbour queries and spatial joins on numpy arrays, each
// the host job rtusim runs, with the GIL released.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "host/devices/device_settings.h"
#include "host/jobs/join.h"
#include "host/jobs/query.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"
#include "python/rtu_module.h"

namespace rtu::pymod {
namespace {

// An (N, K) float array as float32 rows.
std::vector<float> rows_from_numpy(const py::handle& obj, const char* name, py::ssize_t k) {
  py::array a = py::array::ensure(obj);
  if (!a || a.ndim() != 2 || a.shape(1) != k || a.dtype().kind() != 'f')
    fail(std::string(name) + ": expected a float array of shape (N, " + std::to_string(k) + ")");
  using F32 = py::array_t<float, py::array::c_style | py::array::forcecast>;
  const F32 f = F32::ensure(a);
  return std::vector<float>(f.data(), f.data() + f.size());
}

// Points as an (N, 3) float array (copied to float32).
std::vector<hw::Vec3> points_from_numpy(const py::handle& obj, const char* name) {
  const std::vector<float> v = rows_from_numpy(obj, name, 3);
  std::vector<hw::Vec3> p(v.size() / 3);
  if (!p.empty()) std::memcpy(p.data(), v.data(), p.size() * sizeof(hw::Vec3));
  return p;
}

// rtu.query: the job of rtusim query on numpy points; the answers as arrays.
py::dict query(const py::handle& points, const py::handle& queries, float radius, const std::string& kind,
               uint32_t bound, bool timed, const std::string& format, const std::string& config,
               const std::vector<std::string>& sets, int threads, const std::string& order) {
  host::QueryJobOptions o;
  if (order != "input" && order != "morton") fail("order: '" + order + "' is not input or morton");
  o.morton_order = order == "morton";
  o.points = points_from_numpy(points, "points");
  if (!queries.is_none()) o.queries = points_from_numpy(queries, "queries");
  if (kind != "radius" && kind != "count" && kind != "nearest")
    fail("kind: '" + kind + "' is not radius, count or nearest");
  o.what.kind = kind == "radius"  ? hw::PointQuery::kRadius
                : kind == "count" ? hw::PointQuery::kCount
                                  : hw::PointQuery::kNearest;
  o.what.max_results = bound;
  o.radius = radius;
  o.format = hw::format_from_spec(format);
  o.timed = timed;
  if (timed) o.timing = host::timing_config_from(config, sets);
  o.threads = check_threads(threads);
  host::QueryJobResult r;
  {
    py::gil_scoped_release nogil;
    r = host::run_query_job(o);
  }
  const size_t n = r.answers.size();
  std::vector<uint64_t> offsets(n + 1, 0), counts(n);
  std::vector<uint32_t> ids;
  std::vector<uint8_t> overflow(n);
  for (size_t i = 0; i < n; ++i) {
    counts[i] = r.answers[i].count;
    overflow[i] = r.answers[i].overflow;
    ids.insert(ids.end(), r.answers[i].ids.begin(), r.answers[i].ids.end());
    offsets[i + 1] = ids.size();
  }
  py::dict d;
  const py::ssize_t m = py::ssize_t(ids.size()), nn = py::ssize_t(n);
  d["ids"] = give(std::move(ids), py::dtype::of<uint32_t>(), {m}, {4});
  d["offsets"] = give(std::move(offsets), py::dtype::of<uint64_t>(), {nn + 1}, {8});
  d["counts"] = give(std::move(counts), py::dtype::of<uint64_t>(), {nn}, {8});
  d["overflow"] = give(std::move(overflow), py::dtype::of<bool>(), {nn}, {1});
  d["stats"] = to_python(host::query_json(o, r));
  return d;
}

// rtu.join: the job of rtusim join on numpy arrays; the pairs as an (P, 2) array.
py::dict join(const py::object& segments, const py::object& probes, const py::object& polygons,
              const py::object& points, bool timed, const std::string& format, const std::string& config,
              const std::vector<std::string>& sets, int threads) {
  host::JoinJobOptions o;
  o.polygons = !polygons.is_none();
  if (o.polygons) {
    for (const py::handle& p : polygons) {
      const std::vector<float> v = rows_from_numpy(p, "polygons[i]", 2);
      hw::Polygon2 poly;
      for (size_t i = 0; i + 1 < v.size(); i += 2) poly.push_back(hw::Point2{v[i], v[i + 1]});
      o.polys.push_back(std::move(poly));
    }
    const std::vector<float> q = rows_from_numpy(points, "points", 2);
    for (size_t i = 0; i + 1 < q.size(); i += 2) o.points.push_back(hw::Point2{q[i], q[i + 1]});
  } else {
    for (const auto& [obj, out] : {std::pair{&segments, &o.a}, std::pair{&probes, &o.b}}) {
      const std::vector<float> v = rows_from_numpy(*obj, obj == &segments ? "segments" : "probes", 4);
      for (size_t i = 0; i + 3 < v.size(); i += 4)
        out->push_back(hw::Segment2{{v[i], v[i + 1]}, {v[i + 2], v[i + 3]}});
    }
  }
  o.format = hw::format_from_spec(format);
  o.timed = timed;
  if (timed) o.timing = host::timing_config_from(config, sets);
  o.threads = check_threads(threads);
  host::JoinJobResult r;
  {
    py::gil_scoped_release nogil;
    r = host::run_join_job(o);
  }
  std::vector<uint32_t> flat;
  for (const auto& [x, y] : r.pairs) {
    flat.push_back(x);
    flat.push_back(y);
  }
  py::dict d;
  const py::ssize_t n = py::ssize_t(r.pairs.size());
  d["pairs"] = give(std::move(flat), py::dtype::of<uint32_t>(), {n, 2}, {8, 4});
  d["stats"] = to_python(host::join_json(o, r));
  return d;
}

}  // namespace

void register_queries(py::module_& m) {
  m.def("query", &query, py::arg("points"), py::arg("queries"), py::arg("radius"), py::arg("kind"),
        py::arg("bound"), py::arg("timed"), py::arg("format"), py::arg("config"), py::arg("sets"),
        py::arg("threads"), py::arg("order"));
  m.def("join", &join, py::arg("segments"), py::arg("probes"), py::arg("polygons"), py::arg("points"),
        py::arg("timed"), py::arg("format"), py::arg("config"), py::arg("sets"), py::arg("threads"));
}

}  // namespace rtu::pymod
