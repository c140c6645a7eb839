#pragma once
// One fields.h5 for an FFT cell distributed over MPI slabs (fft/slab.hpp): rank 0 writes the file the
// one-process run writes, the other ranks send it their slabs.
//
// Memory: rank 0 receives one rank's slab of one field at a time into one buffer and writes it as a
// piece of the dataset (FieldWriter::add_in_pieces) before it receives the next, so it holds its own
// fields plus one slab of one field, never a whole field; gathering a field to rank 0 first would need
// Ntot · 9 doubles there (7.7 GB for one tensor field at 1024³), i.e. the memory the distribution saves.
// The other ranks send from their field arrays (no copy). Collective: every rank calls it at every
// output step with fields.
#include <mpi.h>

#include <algorithm>
#include <array>
#include <span>
#include <vector>

#include "softhom/fft/slab.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/rve/fft_solver.hpp"

namespace softhom::jobs {

/// One field of fields.h5 of an FFT cell: its dataset name, values, components, centering and unit.
struct RveFieldView {
  const char* name;
  const std::vector<double>* values;
  int components;
  io::Centering centering;
  const char* unit;
};

/// The fields an FFT cell writes at an output step, in file order (one list for the one-process and
/// the distributed writer); `displacement` in the components of the frame the cell is shown in.
inline std::array<RveFieldView, 6> rve_field_views(const rve::RveFields& f, const std::vector<double>& displacement) {
  return {{{"F", &f.F, 9, io::Centering::cell, "1"},
           {"P", &f.P, 9, io::Centering::cell, "MPa"},
           {"sigma", &f.sigma, 9, io::Centering::cell, "MPa"},
           {"von_mises", &f.von_mises, 1, io::Centering::cell, "MPa"},
           {"fiber_fraction", &f.fiber_fraction, 1, io::Centering::cell, "1"},
           {"displacement", &displacement, 3, io::Centering::node, "cell_size unit"}}};
}

/// `writer` on rank 0 (inside begin_step/end_step), null elsewhere; `f` this rank's slab of the fields
/// (cells of its planes i3, corner nodes of its planes, the last rank's also of i3 = n3).
inline void write_slab_fields(io::FieldWriter* writer, const fft::SlabDecomposition& d, const rve::RveFields& f,
                              const std::vector<double>& displacement) {
  const std::array<int, 3>& n = d.grid().n;
  const std::size_t cell_plane = d.plane_voxels(), node_plane = std::size_t(n[0] + 1) * (n[1] + 1);
  // Corner planes of rank r: its planes i3, and the plane i3 = n3 on the rank holding the last plane.
  auto node_planes = [&](int r) {
    const fft::Slab& s = d.slab(r);
    return std::size_t(s.count) + (s.count > 0 && s.begin + s.count == n[2] ? 1 : 0);
  };
  std::vector<double> buffer;  // rank 0: one slab of one field
  int tag = 90;
  for (const RveFieldView& field : rve_field_views(f, displacement)) {
    ++tag;
    auto values_of = [&](int r) {
      const std::size_t planes = field.centering == io::Centering::cell ? std::size_t(d.slab(r).count) : node_planes(r);
      return planes * (field.centering == io::Centering::cell ? cell_plane : node_plane) * std::size_t(field.components);
    };
    if (d.rank() != 0) {
      if (d.slab().count > 0)
        MPI_Send(field.values->data(), int(values_of(d.rank())), MPI_DOUBLE, 0, tag, d.comm());
      continue;
    }
    int next = 0;
    writer->add_in_pieces(
        field.name, field.components, field.centering,
        [&]() -> std::span<const double> {
          while (next < d.size() && d.slab(next).count == 0) ++next;
          if (next == d.size()) return {};
          const int r = next++;
          if (r == 0) return {field.values->data(), field.values->size()};
          buffer.resize(values_of(r));
          MPI_Recv(buffer.data(), int(buffer.size()), MPI_DOUBLE, r, tag, d.comm(), MPI_STATUS_IGNORE);
          return {buffer.data(), buffer.size()};
        },
        field.unit);
  }
}

}  // namespace softhom::jobs
