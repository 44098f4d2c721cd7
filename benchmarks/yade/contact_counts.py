"""Coordination of a YADE packing with rattlers removed, shared by the YADE reference
scripts of this folder (plain Python: no YADE import, so it runs and is checked anywhere).

Over force-carrying interactions (``it.isReal`` and a non-zero normal force): z = 2 C_gg / N
(grain-grain contacts over all grains); grains with fewer than ``min_contacts`` contacts
(walls included) are removed repeatedly as rattlers; z_nr = 2 C_gg' / N' over the grains left
and z_walls_nr = 2 (C_gg' + C_gw') / N', a wall contact counted like a grain contact
(docs/explanations/runs.md, mechanical coordination).
"""


def contact_stats(interactions, grain_ids, is_wall, min_contacts):
    """(z, z_nr, rattler fraction, z_walls_nr) of the ``interactions`` (YADE's
    ``O.interactions``) between the grains ``grain_ids`` and the walls ``is_wall`` (a set of
    body ids)."""
    ncont = {i: 0 for i in grain_ids}
    nwall = {i: 0 for i in grain_ids}
    neigh = {i: [] for i in grain_ids}
    n_gg = 0
    for it in interactions:
        if not it.isReal or it.phys.normalForce.squaredNorm() == 0.0:
            continue
        a, b = it.id1, it.id2
        wa, wb = a in is_wall, b in is_wall
        if wa and wb:
            continue
        if wa or wb:
            ncont[b if wa else a] += 1
            nwall[b if wa else a] += 1
            continue
        n_gg += 1
        ncont[a] += 1
        ncont[b] += 1
        neigh[a].append(b)
        neigh[b].append(a)
    alive = set(grain_ids)
    stack = [i for i in grain_ids if ncont[i] < min_contacts]
    while stack:
        i = stack.pop()
        if i not in alive:
            continue
        alive.discard(i)
        for j in neigh[i]:
            if j in alive:
                ncont[j] -= 1
                if ncont[j] < min_contacts:
                    stack.append(j)
    n_gg_alive = sum(1 for i in alive for j in neigh[i] if j in alive) // 2
    n_gw_alive = sum(nwall[i] for i in alive)
    n = len(grain_ids)
    z = 2.0 * n_gg / n
    z_nr = 2.0 * n_gg_alive / len(alive) if alive else 0.0
    z_nr_w = 2.0 * (n_gg_alive + n_gw_alive) / len(alive) if alive else 0.0
    return z, z_nr, 1.0 - len(alive) / n, z_nr_w
