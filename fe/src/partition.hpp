#pragma once
// Element partitions of the distributed macro assembly (fe::Simulation on the petsc path under MPI):
// every rank assembles the elements it owns and owns the matrix rows of the nodes assigned to it.
#include <vector>

#include "softhom/fe/mesh.hpp"

namespace softhom::fe {

/// Recursive coordinate bisection of the element centroids into `parts` sets of equal size (±1): each
/// cut halves the count (in proportion for an odd number of parts) across the longest extent of the
/// set. Deterministic (ties by element number), so every rank computes the same partition without
/// communication. Returns the part of every element.
std::vector<int> partition_elements_rcb(const Mesh& mesh, int parts);

/// The owner of every node: the lowest part among the elements that contain it (interface nodes go
/// to one side; a node of no element to part 0).
std::vector<int> node_owners(const Mesh& mesh, const std::vector<int>& element_part);

}  // namespace softhom::fe
