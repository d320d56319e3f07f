"""The command ``export``: a saved model as C99 source (one pair of files per unit) or JSON."""

from pathlib import Path

from sklearn_ifog.cli._common import EXIT_OK, InputError, one_line
from sklearn_ifog.cli._files import check_output_parent, load_model


def command_export(args):
    """``export``: the model as C99 source (a .h and a .c, both or neither) or JSON."""
    from sklearn_ifog import UnitwiseRegressor
    from sklearn_ifog.export import to_c, to_c_units, to_json

    model_path = Path(args.model)
    model, _ = load_model(model_path)
    if args.c is not None:
        target = Path(args.c)
        if not target.parent.is_dir():
            raise InputError(f"{target}: the directory {target.parent} does not exist")
        try:
            if isinstance(model, UnitwiseRegressor):
                written = to_c_units(model, target, precision=args.precision, prefix=args.prefix)
            else:
                written = {None: to_c(model, target, precision=args.precision, prefix=args.prefix)}
        except (ValueError, TypeError) as error:
            raise InputError(f"{model_path}: cannot export to C: {one_line(error)}") from None
        for unit, (header, source) in written.items():
            which = "" if unit is None else f" (unit {unit!r})"
            print(f"Wrote {header} and {source}{which}")
    else:
        check_output_parent(args.json)
        try:
            written = to_json(model, args.json)
        except (ValueError, TypeError) as error:
            raise InputError(f"{model_path}: cannot export to JSON: {one_line(error)}") from None
        print(f"Wrote {written}")
    return EXIT_OK
