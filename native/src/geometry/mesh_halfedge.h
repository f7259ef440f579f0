// The OpenMesh half-edge structure behind FitMesh (internal to the fit sources).
#pragma once

#include "geometry/mesh.h"

#include <OpenMesh/Core/Mesh/TriConnectivity.hh>

#include <vector>

namespace sd::fit {

/// Connectivity only: positions stay in FitMesh (double precision).
using OpenMeshTri = OpenMesh::TriConnectivity;

struct FitMesh::HalfEdge {
    OpenMeshTri mesh;
    /// Input vertex of each OpenMesh vertex: faces OpenMesh refuses (complex edges or
    /// vertices) are added on copies of their vertices, so several may map to one.
    std::vector<int32_t> input_vertex;
};

}  // namespace sd::fit
