"""`testbed export-onnx NAME_OR_PATH --out FILE.onnx [--name NAME]`: export a shipped
predictor ("improved", "paper") or a weights .npz to an ONNX file with the bench's
contract (learned_contact.export.onnx_export), then report how closely the file agrees with
the compiled predictor on held-out poses."""

from __future__ import annotations

NAME = "export-onnx"
HELP = "export a learned predictor to ONNX (the bench's contract) and check it against the compiled one"


def add_arguments(parser) -> None:
    parser.add_argument("predictor", metavar="NAME_OR_PATH", help="'improved', 'paper' or a weights .npz")
    parser.add_argument("--out", required=True, metavar="FILE.onnx", help="the ONNX file to write")
    parser.add_argument("--name", default=None, help="the model's metadata name (default: the predictor's)")
    parser.add_argument("--probe", type=int, default=200, metavar="N",
                        help="held-out poses per set (general, stacking) for the agreement check (default 200)")


def run(args) -> int:
    from learned_contact.export.onnx_check import agreement
    from learned_contact.export.onnx_export import export_onnx
    from testbed.errors import TestbedError

    if args.probe < 1:
        raise TestbedError(f"--probe {args.probe}: expected a positive number of poses")
    path = export_onnx(args.predictor, args.out, name=args.name)
    print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB): inputs p_AB, R_AB, size_A, size_B; "
          "outputs point_A, normal_A, depth")
    figures = agreement(path, args.predictor, n=args.probe)
    print(f"agreement with the compiled predictor on {figures['n']} held-out poses (float32 inputs): "
          f"max |point| diff {figures['point_m']:.2e} m, max normal angle {figures['normal_deg']:.2e} deg, "
          f"max |depth| diff {figures['depth_m']:.2e} m")
    return 0
