"""World-frame arrays of polyhedron bodies as the contact kernels take them (shared by the
polyhedron contact tests)."""

from grainlab.engine.detect.polyhedron_narrow_phase import world_polyhedra


def body_arrays(lib, state):
    """Function n -> the kernels' world-frame arrays of polyhedron body n (and its centre)."""
    _, bvs, wv, bfs, wn, wo = world_polyhedra(state, lib)

    def arrays(n):
        s = state.shape_ids[n]
        f0, fc = lib.face_start[s], lib.face_count[s]
        e0, ec = lib.edge_start[s], lib.edge_count[s]
        v0, vc = lib.vertex_start[s], lib.vertex_count[s]
        return (wv[bvs[n]:bvs[n + 1]], wn[bfs[n]:bfs[n + 1]], wo[bfs[n]:bfs[n + 1]],
                lib.face_vertex_start[f0:f0 + fc + 1], lib.face_vertices, lib.edges[e0:e0 + ec],
                lib.edge_faces[e0:e0 + ec], lib.vertex_neighbour_start[v0:v0 + vc + 1],
                lib.vertex_neighbours, state.positions[n])

    return arrays
