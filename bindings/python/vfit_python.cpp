// SPDX-License-Identifier: Apache-2.0
// The Python module `vfit` (pybind11): meshes, bodies, fits and dressed characters with numpy
// arrays in and out. Positions are float32 arrays of shape (V, 3) in metres, triangles int32
// (T, 3), poses float64 (75,) (24 joints' axis-angle rotations, then the root translation, as
// in the C API's conventions, bindings/c/vfit.h). Arrays a Mesh hands out are views of its
// memory (no copy, read-only; they keep the mesh alive); a DressedCharacter's positions are
// views that the next step() overwrites. The GIL is released while the engine works. Errors:
// vfit.Error (a ValueError) naming the input, for what vfit::Error reports.
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "../binding_support.h"
#include "vfit/engine/animate/dressed_character.h"
#include "vfit/engine/engine.h"
#include "vfit/engine/fit/fit_feedback.h"
#include "vfit/engine/fit/fit_report_json.h"
#include "vfit/geometry/body/pose_io.h"
#include "vfit/geometry/garment/catalogue.h"
#include "vfit/geometry/mesh/mesh_io.h"
#include "vfit/kernels/error.h"
#include "vfit/kernels/version.h"

namespace py = pybind11;

namespace {

using Floats = py::array_t<float, py::array::c_style | py::array::forcecast>;
using Ints = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;
using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

struct PyMesh {
  std::shared_ptr<vfit::Mesh> mesh;
};

// A read-only (n, 3) view of `data`, kept alive by `owner`.
template <class T> py::array view(const T* data, std::size_t rows, py::handle owner) {
  py::array a(py::dtype::of<T>(), {static_cast<py::ssize_t>(rows), py::ssize_t(3)},
              {static_cast<py::ssize_t>(3 * sizeof(T)), static_cast<py::ssize_t>(sizeof(T))}, data, owner);
  a.attr("flags").attr("writeable") = false;
  return a;
}

vfit::Mesh mesh_from_arrays(const Floats& positions, const Ints& triangles) {
  if (positions.ndim() != 2 || positions.shape(1) != 3) throw std::invalid_argument("positions must be (V, 3)");
  if (triangles.ndim() != 2 || triangles.shape(1) != 3) throw std::invalid_argument("triangles must be (T, 3)");
  return vfit::bindings::mesh_from_arrays(positions.data(), static_cast<std::size_t>(positions.shape(0)),
                                          triangles.data(), static_cast<std::size_t>(triangles.shape(0)));
}

vfit::Pose pose_from_array(const Doubles& values) {
  if (values.size() != 75) throw std::invalid_argument("a pose is 75 numbers: 24 × 3 axis-angle, then the translation");
  return vfit::bindings::pose_from_values(values.data());
}

struct PyBody {
  vfit::SourcedBody made;
  std::shared_ptr<const vfit::Body> posed;
  bool at_rest = true;
};

std::unique_ptr<vfit::Engine> make_engine(int threads, const std::string& backend, const std::string& device) {
  vfit::EngineOptions o;
  o.threads = threads;
  o.backend = vfit::parse_backend(backend);
  o.device = device;
  return std::make_unique<vfit::Engine>(o);
}

struct PyFit {
  std::shared_ptr<const vfit::Body> body;
  bool at_rest = true;
  vfit::FitResult result;
  std::string report_json;
};

PyBody make_body(const vfit::BodySource& source, int threads) {
  PyBody b;
  {
    py::gil_scoped_release release;
    b.made = make_engine(threads, "tbb", "")->make_body(source);
  }
  b.posed = std::make_shared<const vfit::Body>(b.made.body);
  return b;
}

struct PyCharacter {
  std::shared_ptr<const vfit::Body> body;
  std::unique_ptr<vfit::DressedCharacter> character;
};

py::dict frame_dict(const vfit::FrameReport& r) {
  py::dict d;
  d["lbs_ms"] = r.lbs_ms;
  d["physics_ms"] = r.physics_ms;
  d["blend_ms"] = r.blend_ms;
  d["cleanup_ms"] = r.cleanup_ms;
  d["layering_ms"] = r.layering_ms;
  d["total_ms"] = r.total_ms;
  d["restarted"] = r.restarted;
  d["diverged"] = r.diverged;
  d["left_inside_1mm"] = r.left_inside_1mm;
  d["left_crossing"] = r.left_crossing;
  return d;
}

} // namespace

PYBIND11_MODULE(vfit, m) {
  m.doc() = "vfit: automatic 3D garment fitting and cloth simulation (C++ engine, numpy arrays)";
  m.attr("__version__") = vfit::version();
  m.attr("git_commit") = vfit::git_commit();
  static py::exception<vfit::Error> error(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const vfit::Error& e) {
      PyErr_SetString(error.ptr(), e.what());
    }
  });

  py::class_<PyMesh>(m, "Mesh", "A triangle mesh: positions (V, 3) float32 m, triangles (T, 3) int32.")
      .def(py::init([](const Floats& positions, const Ints& triangles) {
             return PyMesh{std::make_shared<vfit::Mesh>(mesh_from_arrays(positions, triangles))};
           }),
           py::arg("positions"), py::arg("triangles"))
      .def_property_readonly("positions",
                             [](py::object self) {
                               const auto& mesh = *self.cast<PyMesh&>().mesh;
                               return view(mesh.positions.data(), mesh.vertex_count(), self);
                             })
      .def_property_readonly("triangles",
                             [](py::object self) {
                               const auto& mesh = *self.cast<PyMesh&>().mesh;
                               return view(mesh.triangles.data(), mesh.face_count(), self);
                             })
      .def_property_readonly("vertex_count", [](const PyMesh& s) { return s.mesh->vertex_count(); })
      .def_property_readonly("triangle_count", [](const PyMesh& s) { return s.mesh->face_count(); })
      .def("__repr__", [](const PyMesh& s) {
        return "<vfit.Mesh " + std::to_string(s.mesh->vertex_count()) + " vertices, " +
               std::to_string(s.mesh->face_count()) + " triangles>";
      });

  m.def(
      "read_mesh",
      [](const std::string& path) {
        vfit::ParsedMesh parsed;
        {
          py::gil_scoped_release release;
          parsed = vfit::read_mesh(path);
        }
        return PyMesh{std::make_shared<vfit::Mesh>(std::move(parsed.mesh))};
      },
      py::arg("path"), "Reads OBJ, PLY, OFF, STL or glTF/GLB (every mesh of the file merged).");
  m.def(
      "write_mesh",
      [](const std::string& path, const PyMesh& mesh) {
        py::gil_scoped_release release;
        vfit::write_mesh(path, *mesh.mesh);
      },
      py::arg("path"), py::arg("mesh"), "Writes OBJ, PLY, OFF, STL or GLB by the extension, atomically.");
  m.def(
      "catalogue_garment",
      [](const std::string& type, const std::string& size, const std::string& rest_pose, std::size_t vertices) {
        vfit::GarmentOptions o;
        o.type = vfit::parse_garment_type(type);
        o.size = size;
        o.pose = vfit::bindings::rest_pose_named(rest_pose);
        o.target_vertices = vertices;
        py::gil_scoped_release release;
        return PyMesh{std::make_shared<vfit::Mesh>(vfit::make_garment(o).mesh)};
      },
      py::arg("type"), py::arg("size") = "M", py::arg("rest_pose") = "tpose", py::arg("vertices") = 5000,
      "A catalogue garment (tee, long_sleeve, trousers, shorts, dress, skirt) with exactly `vertices` vertices.");

  py::class_<PyBody>(m, "Body", "A rigged body, at rest and posed (metres, Y up, facing +Z).")
      .def_static(
          "mannequin",
          [](const py::object& measurements, const std::string& rest_pose, std::size_t vertices, int threads) {
            vfit::BodySource source;
            vfit::MannequinOptions& mo = source.request.mannequin;
            if (!measurements.is_none())
              for (const auto& [key, value] : measurements.cast<py::dict>())
                mo.measurements[key.cast<std::string>()] = value.cast<double>();
            mo.pose = vfit::bindings::rest_pose_named(rest_pose);
            mo.target_vertices = vertices;
            return make_body(source, threads);
          },
          py::arg("measurements") = py::none(), py::arg("rest_pose") = "apose", py::arg("vertices") = 7000,
          py::arg("threads") = 0,
          "The parametric mannequin; measurements: a dict of any of height, crotch_height, knee_height, arm_length, "
          "forearm_length, shoulder_width, chest, waist, hip, thigh, calf (m).")
      .def_static(
          "read",
          [](const std::string& path, int threads) {
            vfit::BodySource source;
            source.request.source = path;
            return make_body(source, threads);
          },
          py::arg("path"), py::arg("threads") = 0, "A body from an SMPL-format .npz, a rigged glTF, or a mesh.")
      .def(
          "set_pose",
          [](PyBody& b, const py::object& pose) {
            vfit::Pose p = py::isinstance<py::str>(pose)
                               ? vfit::pose_by_name_or_file(pose.cast<std::string>(), b.made.loaded.rest.rest_pose)
                               : pose_from_array(pose.cast<Doubles>());
            py::gil_scoped_release release;
            b.posed = std::make_shared<const vfit::Body>(b.made.loaded.posed(p));
            b.at_rest = p.is_rest();
          },
          py::arg("pose"), "Poses the body: 75 numbers, a built-in pose name (\"demo\", ...) or a pose JSON file.")
      .def_property_readonly("mesh",
                             [](const PyBody& b) { return PyMesh{std::make_shared<vfit::Mesh>(b.posed->mesh)}; })
      .def_property_readonly("kind", [](const PyBody& b) { return b.made.loaded.kind; })
      .def_property_readonly("at_rest", [](const PyBody& b) { return b.at_rest; });

  py::class_<PyFit>(m, "FitResult", "Fitted garments (metres, the body's frame) and the fit report.")
      .def_property_readonly("garments",
                             [](const PyFit& f) {
                               std::vector<PyMesh> out;
                               for (const vfit::FittedGarment& g : f.result.garments)
                                 out.push_back(PyMesh{std::make_shared<vfit::Mesh>(g.mesh)});
                               return out;
                             })
      .def_property_readonly("names",
                             [](const PyFit& f) {
                               std::vector<std::string> out;
                               for (const vfit::FittedGarment& g : f.result.garments)
                                 out.push_back(g.name);
                               return out;
                             })
      .def_property_readonly("report_json", [](const PyFit& f) { return f.report_json; })
      .def_property_readonly("report",
                             [](const PyFit& f) { return py::module_::import("json").attr("loads")(f.report_json); })
      .def_property_readonly("verdict",
                             [](const PyFit& f) { return vfit::size_verdict_name(f.result.report.verdict); });

  m.def(
      "fit",
      [](const PyBody& body, const std::vector<PyMesh>& garments, const py::object& names, bool simulate,
         const std::string& fabric, double clearance, int threads, const std::string& backend) {
        if (garments.empty()) throw std::invalid_argument("fit: no garments");
        std::vector<vfit::FitGarmentInput> inputs(garments.size());
        const auto given = names.is_none() ? std::vector<std::string>() : names.cast<std::vector<std::string>>();
        if (!given.empty() && given.size() != garments.size()) throw std::invalid_argument("fit: one name per garment");
        for (std::size_t g = 0; g < garments.size(); ++g) {
          inputs[g].name = given.empty() ? "garment" + std::to_string(g) : given[g];
          inputs[g].mesh = *garments[g].mesh;
        }
        vfit::FitOptions o;
        o.simulate = simulate;
        o.fabric = fabric;
        if (clearance > 0) o.clearance = clearance;
        PyFit f;
        f.body = body.posed;
        f.at_rest = body.at_rest;
        {
          py::gil_scoped_release release;
          const auto engine = make_engine(threads, backend, "");
          f.result = engine->fit(*body.posed, inputs, o);
          f.report_json =
              vfit::fit_report_json(f.result.report, o, vfit::fit_report_context(*body.posed, body.made.loaded));
        }
        return f;
      },
      py::arg("body"), py::arg("garments"), py::arg("names") = py::none(), py::arg("simulate") = true,
      py::arg("fabric") = "cotton_jersey", py::arg("clearance") = 0.0, py::arg("threads") = 0,
      py::arg("backend") = "tbb",
      "Fits garments (inner first) onto the body as posed, as `vfit fit` does; threads 0: every core.");

  py::class_<PyCharacter>(m, "DressedCharacter",
                          "A body and the garments fitted onto it at rest, stepped frame by frame (seed 001 §7).")
      .def(py::init([](const PyBody& body, const PyFit& fit, bool physics, int threads) {
             vfit::bindings::require_fit_at_rest(*fit.body, fit.at_rest, body.made.body);
             vfit::AnimationOptions o;
             o.physics = physics;
             o.threads = threads;
             PyCharacter c;
             c.body = fit.body;
             py::gil_scoped_release release;
             c.character = std::make_unique<vfit::DressedCharacter>(*fit.body, fit.result.garments, o);
             return c;
           }),
           py::arg("body"), py::arg("fit"), py::arg("physics") = true, py::arg("threads") = 0)
      .def(
          "step",
          [](PyCharacter& c, const Doubles& pose, double dt) {
            const vfit::Pose p = pose_from_array(pose);
            const vfit::FrameReport* r = nullptr;
            {
              py::gil_scoped_release release;
              r = &c.character->step(p, dt);
            }
            return frame_dict(*r);
          },
          py::arg("pose"), py::arg("dt"), "One frame, dt seconds after the previous; returns its timings and counts.")
      .def_property_readonly("garment_count", [](const PyCharacter& c) { return c.character->garment_count(); })
      .def(
          "garment_positions",
          [](py::object self, std::size_t g) {
            const auto& c = *self.cast<PyCharacter&>().character;
            if (g >= c.garment_count()) throw py::index_error("no such garment");
            const std::span<const float> p = c.garment_positions(g);
            return view(p.data(), p.size() / 3, self);
          },
          py::arg("g"), "Garment g after the last step: a (V, 3) view the next step overwrites (copy to keep).")
      .def("body_positions", [](py::object self) {
        const std::span<const float> p = self.cast<PyCharacter&>().character->body_positions();
        return view(p.data(), p.size() / 3, self);
      });

  m.def(
      "animate",
      [](const PyBody& body, const PyFit& fit, const Doubles& poses, double fps, bool physics, int threads) {
        if (poses.ndim() != 2 || poses.shape(1) != 75) throw std::invalid_argument("poses must be (frames, 75)");
        if (!(fps > 0)) throw std::invalid_argument("fps must be positive");
        vfit::bindings::require_fit_at_rest(*fit.body, fit.at_rest, body.made.body);
        vfit::AnimationOptions o;
        o.physics = physics;
        o.threads = threads;
        const auto frames = static_cast<std::size_t>(poses.shape(0));
        std::vector<vfit::Pose> ps;
        for (std::size_t f = 0; f < frames; ++f) {
          try {
            ps.push_back(vfit::bindings::pose_from_values(poses.data() + 75 * f));
          } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("pose " + std::to_string(f) + ": " + e.what());
          }
        }
        std::vector<std::vector<float>> out(fit.result.garments.size());
        {
          py::gil_scoped_release release;
          vfit::DressedCharacter c(*fit.body, fit.result.garments, o);
          for (std::size_t f = 0; f < frames; ++f) {
            c.step(ps[f], 1.0 / fps);
            for (std::size_t g = 0; g < out.size(); ++g) {
              const auto p = c.garment_positions(g);
              out[g].insert(out[g].end(), p.begin(), p.end());
            }
          }
        }
        py::list result;
        for (std::vector<float>& g : out) {
          const auto v = static_cast<py::ssize_t>(g.size() / 3 / std::max<std::size_t>(frames, 1));
          py::array_t<float> a({static_cast<py::ssize_t>(frames), v, py::ssize_t(3)});
          std::copy(g.begin(), g.end(), a.mutable_data());
          result.append(a);
        }
        return result;
      },
      py::arg("body"), py::arg("fit"), py::arg("poses"), py::arg("fps") = 30.0, py::arg("physics") = true,
      py::arg("threads") = 0,
      "Plays poses (frames, 75) on the dressed body; returns per garment an array (frames, V, 3).");
}
