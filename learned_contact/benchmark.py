"""Speed benchmark (a script, not a test): learned predictor versus Drake queries.

    python -m learned_contact.benchmark [--n 2000] [--single 300]

In one run, on the same labelled stacking and general poses, times
- the numpy predictor, one pair per call and batched;
- the same MLP run by torch (features in numpy), one pair per call and batched;
- Drake's point-pair query for one pair: query only (pose already in the context)
  and with the pose set per call (what answering a new pose costs);
- Drake's hydroelastic query for one pair (ComputeContactSurfaces), query only and
  with the pose set per call, and the full static label (adds the per-face loop).
Prints microseconds per pair and the ratios the issue asks for.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def _per_pair(fn, repeats: int, pairs: int) -> float:
    """Best-of-3 microseconds per pair of calling fn() `repeats` times on `pairs` pairs each."""
    best = np.inf
    for _ in range(3):
        t = time.perf_counter()
        for _ in range(repeats):
            fn()
        best = min(best, (time.perf_counter() - t) / (repeats * pairs))
    return best * 1e6


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2000, help="poses per distribution")
    parser.add_argument("--single", type=int, default=300, help="poses timed one per call")
    args = parser.parse_args(argv)

    import torch
    from pydrake.geometry import HydroelasticContactRepresentation

    from learned_contact import load_predictor
    from learned_contact.encodings import canonicalise, features
    from learned_contact.labels import _pair_scene, _query, make_dataset
    from learned_contact.mlp import NumpyMLP
    from learned_contact.paper_mlp import predict_paper
    from learned_contact.predictor import DEFAULT_WEIGHTS, POINT_STEP
    from testbed.contact_geometry import static_pressure, surface_face_arrays
    from testbed.containers import CONTAINER_TYPES

    torch.set_num_threads(1)
    pred = load_predictor()
    pred_path = DEFAULT_WEIGHTS
    data = [make_dataset(d, args.n, 424_242, progress=False) for d in ("stacking", "general")]
    p = np.concatenate([d.p_AB for d in data])
    R = np.concatenate([d.R_AB for d in data])
    sA = np.concatenate([d.size_A for d in data])
    sB = np.concatenate([d.size_B for d in data])
    n = len(p)
    idx = np.random.default_rng(0).choice(n, size=min(args.single, n), replace=False)

    res = {}
    pred.predict(p, R, size_A=sA, size_B=sB)  # warm up
    res["numpy, one pair per call"] = _per_pair(
        lambda: [pred.predict(p[i], R[i], size_A=sA[i], size_B=sB[i]) for i in idx], 1, len(idx))
    res["numpy, batched"] = _per_pair(lambda: pred.predict(p, R, size_A=sA, size_B=sB), 1, n)

    mlp = pred.mlp
    layers = []
    for i, (W, b) in enumerate(zip(mlp.weights, mlp.biases)):
        lin = torch.nn.Linear(*W.shape)
        lin.weight.data = torch.tensor(W.T, dtype=torch.float32)
        lin.bias.data = torch.tensor(b, dtype=torch.float32)
        layers.append(lin)
        if i < len(mlp.weights) - 1:
            layers.append(torch.nn.SiLU() if mlp.activation == "silu" else torch.nn.Tanh())
    net = torch.nn.Sequential(*layers).eval()
    x_mean = torch.tensor(mlp.x_mean, dtype=torch.float32)
    x_std = torch.tensor(mlp.x_std, dtype=torch.float32)

    def torch_predict(pp, RR, a, b):
        S, p_c, R_c = canonicalise(pp, RR)
        x, pe, ne = features(p_c, R_c, 0.5 * a, 0.5 * b)
        with torch.no_grad():
            y = net((torch.from_numpy(x).float() - x_mean) / x_std).numpy()
        nn = ne + y[:, 3:]
        return S * (pe + POINT_STEP * y[:, :3]), S * nn / np.linalg.norm(nn, axis=1, keepdims=True)

    pt_np, _ = pred.predict(p, R, size_A=sA, size_B=sB)
    pt_t, _ = torch_predict(p, R, sA, sB)
    res["torch (float32), one pair per call"] = _per_pair(
        lambda: [torch_predict(p[i:i + 1], R[i:i + 1], sA[i:i + 1], sB[i:i + 1]) for i in idx], 1, len(idx))
    res["torch (float32), batched"] = _per_pair(lambda: torch_predict(p, R, sA, sB), 1, n)
    S_, p_c, R_c = canonicalise(p, R)
    x_all = features(p_c, R_c, 0.5 * sA, 0.5 * sB)[0]
    res["numpy features only, batched"] = _per_pair(lambda: features(p_c, R_c, 0.5 * sA, 0.5 * sB), 1, n)
    res["numpy MLP only, batched"] = _per_pair(lambda: mlp(x_all), 1, n)
    paper_path = pred_path.parent / "paper_weights.npz"
    if paper_path.is_file():
        with np.load(paper_path) as z:
            paper = NumpyMLP.from_arrays({k: z[k] for k in z.files}, "mlp/")
        res["paper 6-20-18-4 MLP, one pair per call"] = _per_pair(
            lambda: [predict_paper(paper, p[i:i + 1], R[i:i + 1]) for i in idx], 1, len(idx))
        res["paper 6-20-18-4 MLP, batched"] = _per_pair(lambda: predict_paper(paper, p, R), 1, n)

    types = ("1CC", "1AA", "1AAA")
    code = {tuple(CONTAINER_TYPES[t].size): t for t in types}
    scenes = [_pair_scene(code[tuple(a)], code[tuple(b)]) for a, b in zip(sA, sB)]  # per pose, its type pair
    poly = HydroelasticContactRepresentation.kPolygon
    i0 = int(idx[0])
    q = _query(scenes[i0], R[i0], p[i0])
    assert q.ComputePointPairPenetration() and q.ComputeContactSurfaces(poly)  # in contact
    res["drake point-pair, query only"] = _per_pair(q.ComputePointPairPenetration, 2000, 1)
    res["drake hydroelastic, query only"] = _per_pair(lambda: q.ComputeContactSurfaces(poly), 200, 1)
    res["drake point-pair, set pose + query"] = _per_pair(
        lambda: [_query(scenes[i], R[i], p[i]).ComputePointPairPenetration() for i in idx], 1, len(idx))
    res["drake hydroelastic, set pose + query"] = _per_pair(
        lambda: [_query(scenes[i], R[i], p[i]).ComputeContactSurfaces(poly) for i in idx[:100]], 1, len(idx[:100]))

    def full_label(i):
        surfaces = _query(scenes[i], R[i], p[i]).ComputeContactSurfaces(poly)
        return static_pressure(surface_face_arrays(surfaces[0])) if surfaces else None

    res["drake hydroelastic + static CoP (label)"] = _per_pair(lambda: [full_label(i) for i in idx[:100]], 1, len(idx[:100]))

    width = max(len(k) for k in res)
    print(f"poses: {n} ({args.n} stacking + {args.n} general); one-per-call timed on {len(idx)}")
    print(f"torch vs numpy max point difference: {np.abs(pt_t - pt_np).max():.2e} m")
    for k, v in res.items():
        print(f"{k:<{width}}  {v:10.2f} us/pair")
    pp_q, pp_set = res["drake point-pair, query only"], res["drake point-pair, set pose + query"]
    single, batched = res["numpy, one pair per call"], res["numpy, batched"]
    ratios = {
        "one-per-call / drake point-pair (query only)": single / pp_q,
        "one-per-call / drake point-pair (set pose + query)": single / pp_set,
        "drake point-pair (query only) / batched": pp_q / batched,
        "drake point-pair (set pose + query) / batched": pp_set / batched,
        "drake hydroelastic (set pose + query) / batched": res["drake hydroelastic, set pose + query"] / batched,
        "drake hydroelastic (set pose + query) / one-per-call": res["drake hydroelastic, set pose + query"] / single,
    }
    print("ratios (targets: one-per-call / point-pair <= 1; point-pair / batched >= 20):")
    for k, v in ratios.items():
        print(f"  {k:<{width + 10}}  {v:8.2f}")
    return {"us_per_pair": res, "ratios": ratios}


if __name__ == "__main__":
    main()
