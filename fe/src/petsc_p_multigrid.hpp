#pragma once
// Two-level p-multigrid for the displacement block of quadratic-tet meshes (petsc_solve.cpp): the fine
// level is the P2 field on every node, the coarse level the P1 field on the element vertices, the
// interpolation the P1 shape functions (a mid-edge node takes the mean of its edge's two vertices). The
// coarse operator is the Galerkin product PᵀAP (PETSc's PCMG), which BoomerAMG solves; one Chebyshev
// sweep before and after it smooths the fine level. Why: BoomerAMG's V-cycles on the P2 block itself are
// what the PETSc path spent its time in (93 % of KSPSolve on the cPASMO 0.5 mesh), and the P1 block has
// ~1/8 of the rows.
#include <petscmat.h>

#include <vector>

#include "softhom/fe/mesh.hpp"

namespace softhom::fe {

/// P as a PETSc MPIAIJ matrix. Rows: the displacement block of the distributed system (the nodes owned
/// by each rank in `node_owner`, rank by rank, node order within a rank, three components each); columns:
/// the free components (`eq` ≥ 0) of the vertex nodes, numbered the same way. A prescribed fine row is
/// zero; a mid-edge node next to a prescribed vertex component takes half of the free one only (the P1
/// interpolant of a zero boundary value). Hex8 nodes are vertices. Collective.
Mat p_multigrid_interpolation(MPI_Comm comm, int rank, const Mesh& mesh, const std::vector<int>& eq,
                              const std::vector<int>& node_owner);

}  // namespace softhom::fe
