#pragma once
// RVE scene tables → FFT solver inputs, shared by the rve job (jobs/) and the sweep campaigns, so that a
// campaign case is exactly an `softhom rve` scene.
//
// Scene tables: [microstructure] (generated section or imported HDF5 phase image, grid, fiber angle),
// [phases.matrix] / [phases.fiber] (material tables as in `softhom point`), [load] (same syntax as
// `softhom point`), [solver] (discretization, scheme, tolerances, FFTW), [output] (fields).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"

#include "softhom/materials/loading.hpp"
#include "softhom/materials/material.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"

namespace softhom::studies {

/// The phase image (grid frame) of a [microstructure] table; `target_vf` is the requested fraction,
/// `geometry_note` a one-line description. Reads an imported image with io::read_dataset (HDF5: not
/// thread-safe in the Debian build; callers running cases in threads serialise this).
/// The generated-section keys of [microstructure] (shape, arrangement, volume_fraction, radius, width,
/// height, cell_size, section_rotation_deg, fiber_count, min_gap, seed) as a cell description, shared
/// by both RVE engines; `label` gets "<shape> fibers, <arrangement> arrangement".
rve::FiberCellSpec parse_fiber_cell_spec(const toml::table& microstructure, const std::string& path, std::string& label);
rve::PhaseImage build_phase_image(const toml::table& microstructure, double& target_vf, std::string& geometry_note);
/// Reads and checks every key of [microstructure] (InputError naming the first bad one) and returns
/// fiber_angle_deg.
double microstructure_fiber_angle(const toml::table& microstructure);
/// [microstructure] cell = "plate": one fiber layer with traction-free faces (FE engine only; the FFT
/// engine's phase images refuse it).
bool microstructure_is_plate(const toml::table& microstructure);

/// [microstructure.image] (path `p`): a voxel image from HDF5 (io::read_dataset). Keys: file (relative to
/// the scene file), dataset (default "/phase"; C-order [n2][n1] section or [n3][n2][n1] volume; integer
/// = phase ids, matrix_id = 0 / fiber_id = 1 by default, any other id is an error; floating point =
/// fiber fractions in [0, 1]), normal_dataset (optional interface normals, dims + [3]),
/// direction_dataset (optional per-voxel fiber direction, grid frame, dims + [3], non-zero in fiber),
/// voxel_size or cell_size (number or [x, y, z]; default: the dataset's attributes of those names, else
/// cubic voxels with L1 = 1). Every problem is an InputError naming the key. `distributed` (collective):
/// a 3D image is read and held as this rank's slab image (rve/slab_image.hpp), only its planes and halo
/// read from the file (io::read_dataset_planes), when MPI runs more than one rank.
rve::PhaseImage import_phase_image(const toml::table& image, const std::string& p, std::string& geometry_note,
                                   bool distributed = false);

/// The per-user cache directory ${XDG_CACHE_HOME:-$HOME/.cache}/softhom.
std::filesystem::path user_cache_dir();
/// A file a run writes, as written at `field`: relative paths are relative to `out` (the run's --out;
/// empty: the cache), absolute paths must lie under `out` or the cache; a path escaping them ("..")
/// is an InputError. Empty stays empty.
std::filesystem::path resolve_run_file(const std::string& written, const std::filesystem::path& out, const std::string& field);

/// [solver] table → options (defaults when absent); `wisdom` receives solver.fftw_wisdom resolved
/// with resolve_run_file against `out`.
rve::FftSolverOptions parse_fft_solver_options(const toml::table& scene, std::filesystem::path& wisdom,
                                               const std::filesystem::path& out = {});

/// The [output] table of an RVE scene (both engines): which output times get fields, and whether to
/// stop after writing the microstructure. With `control`, listed field times must be output times
/// of its load path.
struct RveOutputSettings {
  std::string fields_mode = "last";  ///< none | last | all | times
  std::vector<double> field_times;
  bool microstructure_only = false;

  bool wants_fields(double t, double t_end) const {
    if (fields_mode == "all") return true;
    if (fields_mode == "last") return std::abs(t - t_end) <= 1e-12 * std::max(1.0, t_end);
    if (fields_mode == "times")
      for (double ft : field_times)
        if (std::abs(t - ft) <= 1e-9 * std::max(1.0, t_end)) return true;
    return false;
  }
};
RveOutputSettings parse_rve_output(const toml::table& scene, const MixedControl* control);

/// [phases] of an RVE scene (also checks the top-level tables): the matrix and the fiber (the matrix
/// when no [phases.fiber] is given; `has_fiber` says which).
struct RvePhases {
  MaterialPtr matrix, fiber;
  bool has_fiber = false;
};
RvePhases parse_rve_phases(const toml::table& scene);
/// [microstructure] of an RVE scene (missing: InputError).
const toml::table& rve_microstructure(const toml::table& scene);
/// [load] of an RVE scene (missing: InputError).
MixedControl parse_rve_load(const toml::table& scene);

/// Everything an FFT RVE run needs, parsed and validated from a scene table (not [output]).
struct RveSceneSetup {
  rve::PhaseImage image;
  MaterialPtr matrix, fiber;
  double fiber_angle_deg = 0.0;
  double target_vf = 0.0;
  std::string geometry_note;
  MixedControl control;
  RveOutputSettings output;
  rve::FftSolverOptions solver;
};

/// Parses [microstructure], [phases], [load], [solver], [output] of an RVE scene (every error an
/// InputError naming the TOML path). `with_load = false` skips [load] (microstructure-only runs);
/// `out` is the run's output directory (for solver.fftw_wisdom). `distributed`: the image is this rank's
/// slab image (rve/slab_image.hpp) when MPI runs more than one rank on a 3D grid, for a solver with
/// FftSolverOptions::distributed (collective); generated cells are voxelized per slab, imported images
/// are read whole and cut.
RveSceneSetup parse_rve_scene(const toml::table& scene, bool with_load = true, const std::filesystem::path& out = {},
                              bool distributed = false);

/// Key documentation of the tables both RVE engines share (top level, microstructure, image, phases,
/// materials, load, output); the engines' [solver] tables are added by rve_scene_tables().
std::vector<keys::TableDoc> rve_common_tables();

/// response.csv layout of an RVE run (load frame): t, F, P, sigma, fiber angle, phase means, iterations.
std::vector<std::string> rve_response_columns();
std::vector<double> rve_response_row(const rve::RveStep& step);

}  // namespace softhom::studies
