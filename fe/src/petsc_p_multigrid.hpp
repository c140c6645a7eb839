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

/// The interpolation and what the coarse level's AMG needs to know about its space.
struct PMultigridSpace {
  Mat interpolation = nullptr;          ///< P (owned by the caller: MatDestroy)
  std::vector<double> coarse_coords;    ///< this rank's coarse vertices' coordinates, x y z per vertex
  std::vector<int> coarse_nodes;        ///< the mesh nodes of these vertices, in the same order
};

/// P as a PETSc MPIAIJ matrix of block size 3. Rows: the displacement block of the distributed system
/// (the nodes owned by each rank in `node_owner`, rank by rank, node order within a rank, three
/// components each); columns: all three components of the vertex nodes, numbered the same way. A free
/// fine row interpolates the free vertex components only (a mid-edge node next to a prescribed vertex
/// component takes half of the free one: the P1 interpolant of a zero boundary value); a prescribed fine
/// row interpolates the prescribed ones (its vertex itself, or the prescribed ends of its edge). The
/// prescribed rows of the fine block hold their diagonal alone, so PᵀAP keeps the free and prescribed
/// coarse components apart while every coarse vertex keeps its three components: the block structure
/// that lets the coarse AMG aggregate by node and use the rigid-body modes (a slender bending part needs
/// its rotations in the coarse space). Hex8 nodes are vertices. Collective.
PMultigridSpace p_multigrid_interpolation(MPI_Comm comm, int rank, const Mesh& mesh, const std::vector<int>& eq,
                                          const std::vector<int>& node_owner);

/// The geometric mean over the nodes whose rows are this rank's rows [row_lo, row_hi) of `A` (three
/// consecutive rows and columns per node, from row_lo on) of the spread
/// λ_max / λ_min of each node's 3 × 3 diagonal block (its symmetric part). Nodes with a prescribed
/// component (a row holding its diagonal alone) or a block that is not positive definite are left out;
/// 1 when none is left. Isotropic solids give a few units whatever the mesh; fibers that stiffen one
/// direction give their stiffness ratio. Collective.
double nodal_block_spread(MPI_Comm comm, Mat A, PetscInt row_lo, PetscInt row_hi);

}  // namespace softhom::fe
