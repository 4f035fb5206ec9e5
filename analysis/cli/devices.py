"""Where ensembles run: `devices` (what this machine offers the member kernels) and the one
``--device`` option (cpu, gpu or auto) of basins, attractors, chart and sweep --no-follow."""

from __future__ import annotations

from dataclasses import asdict
from typing import Annotated

import typer

from analysis.cli.common import JsonOption, app, echo_json, reports_errors

DEVICE_HELP = ("Where the member kernels run: cpu (every core, the C/OpenMP build), gpu (the "
               "CUDA build; needs `pip install bearingdyn[gpu]` and an NVIDIA GPU) or auto "
               "(the GPU for wide ensembles when one is visible, else the cores; see "
               "`bearingdyn devices`).")


def check_device(param: typer.CallbackParam, value: str | None) -> str | None:
    """Option callback: ``value`` is one of the device names, or None where the option may
    be left out (checked before the command runs; whether a GPU is there is checked by the
    command, before any work)."""
    from analysis.integrate.kernels.devices import DEVICES

    if value is not None and value not in DEVICES:
        raise typer.BadParameter(f"one of {', '.join(DEVICES)}, got {value!r}",
                                 param_hint="--device")
    return value


DeviceOption = Annotated[str, typer.Option("--device", help=DEVICE_HELP,
                                           callback=check_device)]
SweepDeviceOption = Annotated[str | None, typer.Option(
    "--device", help="With --no-follow: run the values as members of the member kernels on "
                     "cpu, gpu or auto (sections on whole steps, no 1X phasor); left out: "
                     "value by value through the executor.", callback=check_device)]


def devices_json() -> dict:
    """What ``devices --json`` prints: every device (``kernels.device_info``), why no GPU
    can be used (null when one can) and the rule of ``--device auto``."""
    from analysis.integrate.kernels import device_info
    from analysis.integrate.kernels.devices import AUTO_MIN_MEMBERS, AUTO_MIN_STEPS, gpu_problem

    return {"devices": [asdict(d) for d in device_info()], "gpu_problem": gpu_problem(),
            "auto": {"min_members": AUTO_MIN_MEMBERS, "min_member_steps": AUTO_MIN_STEPS}}


def _gib(value: int | None) -> str:
    return "?" if value is None else f"{value / 2**30:.1f} GiB"


@app.command()
@reports_errors
def devices(as_json: JsonOption = False):
    """What the member kernels can run on: the CPU cores this process may use and every
    visible GPU (name, memory, CuPy and CUDA versions), and the rule of --device auto."""
    info = devices_json()
    if as_json:
        echo_json(info, indent=2)
        return
    for d in info["devices"]:
        if d["kind"] == "cpu":
            typer.echo(f"cpu: {d['name'] or 'unknown'}, {d['cores']} core(s)")
        else:
            typer.echo(f"gpu: {d['name']}, {_gib(d['memory_bytes'])} ({_gib(d['free_bytes'])} "
                       f"free), CuPy {d['cupy_version']}, CUDA {d['cuda_version']}")
    if info["gpu_problem"]:
        from analysis.integrate.kernels.devices import INSTALL_HINT

        typer.echo(f"no GPU: {info['gpu_problem']}; {INSTALL_HINT}")
    rule = info["auto"]
    typer.echo(f"--device auto: the GPU from {rule['min_members']} members and "
               f"{rule['min_member_steps']:.0e} member-steps, else the cores")
