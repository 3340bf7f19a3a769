"""A tiny program that honours the bundled engine's contract, for the harness' tests.

Particles fall under gravity ``G`` (m/s^2) from rest and bounce elastically off the floor z = 0:
ke(t) = sum m g (h0 - z(t)) - analytic, so the harness' numbers can be checked by hand. The scene is a
JSON list of commands; besides ``create`` and ``run`` it knows commands that misbehave on purpose.
"""
import json
import math
import os
import signal
import sys
import time

G = 9.81  # m/s^2; a later revision changes it to make an inconsistent version
STEPPING = [0.002]  # s: the loop times reported by successive runs in one folder (harness run --repeat), in turn


def main(argv):
    args = {"-var": {}}
    i = 0
    while i < len(argv):
        if argv[i] == "-var":
            args["-var"][argv[i + 1]] = argv[i + 2]
            i += 3
        else:
            args[argv[i]] = argv[i + 1]
            i += 2
    log = open(args.get("-log", "log.dem"), "w")

    def error(message, code):
        log.write(f"ERROR: {message}\n")
        log.close()
        print(f"ERROR: {message}", file=sys.stderr)
        sys.exit(code)

    try:
        text = open(args["-in"]).read()
        for name, value in args["-var"].items():
            text = text.replace("${" + name + "}", value)
        commands = json.loads(text)
    except (OSError, ValueError) as exc:
        error(f"cannot read script: {exc}", 2)
    heights, mass, step, dt = [], 1.0, 0, 1e-3
    remove_thermo = False
    thermo = open("thermo.csv", "w")
    thermo.write("step,time,atoms,ke,rke,z\n")
    for command in commands:
        log.write(json.dumps(command) + "\n")
        name = command.get("command")
        if name == "create":
            heights = [float(h) for h in command["heights"]]
            mass = float(command.get("mass", 1.0))
        elif name == "run":
            every = int(command.get("every", 10))
            for _ in range(int(command["steps"]) + 1):
                if step % every == 0:
                    t = step * dt
                    ke, zs = 0.0, []
                    for h in heights:
                        period = 2 * math.sqrt(2 * h / G)
                        tau = t % period
                        tau = tau if tau < period / 2 else period - tau
                        z = h - 0.5 * G * tau * tau
                        zs.append(z)
                        ke += mass * G * (h - z)
                    value = command.get("value_override", ke)
                    thermo.write(f"{step},{t},{len(heights)},{value},0,{sum(zs) / max(len(zs), 1)}\n")
                    thermo.flush()
                step += 1
            step -= 1
        elif name == "warn":
            log.write("WARNING: something to look at\n")
        elif name == "crash":
            os.kill(os.getpid(), signal.SIGSEGV)
        elif name == "hang":
            time.sleep(60)
        elif name == "sleep":
            time.sleep(float(command["seconds"]))
        elif name == "error_exit0":
            log.write("ERROR: lost atoms but exiting with 0\n")
            log.close()
            sys.exit(0)
        elif name == "garbage":
            sys.stdout.buffer.write(b"\xff\xfe bytes that are not UTF-8 \xc3\x28\n")
            log.write("binary: \udcff\n".encode("utf-8", "surrogateescape").decode("latin-1"))
        elif name == "nan":
            thermo.write(f"{step + 1},{(step + 1) * dt},{len(heights)},nan,0,0\n")
        elif name == "no_thermo":
            remove_thermo = True
        elif name == "write":
            with open(command["file"], "w") as handle:
                handle.write(command["text"])
        elif name == "copy":
            with open(command["from"]) as src, open(command["to"], "w") as dst:
                dst.write(src.read())
        elif name == "dump":
            write_vtp(command["file"], heights, mass, step * dt)
        else:
            error(f"unknown command {name!r}", 2)
    # the how-many-th run in this folder picks its loop time: a noisy or slower revision, reproducibly
    runs = int(open(".fake_runs").read()) if os.path.exists(".fake_runs") else 0
    open(".fake_runs", "w").write(str(runs + 1))
    total = STEPPING[runs % len(STEPPING)]
    json.dump({"pair": total / 2, "neigh": 0.0, "comm": 0.0, "modify": 0.0, "output": 0.0, "other": 0.0,
               "total": total, "steps": step, "particles": len(heights), "particle_steps_per_second": 1.0},
              open("timing.json", "w"))
    log.write("run done\n")
    log.close()
    if remove_thermo:
        thermo.close()
        os.remove("thermo.csv")


def write_vtp(path, heights, mass, t):
    import vtk

    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    points = vtk.vtkPoints()
    velocity = vtk.vtkDoubleArray()
    velocity.SetName("velocity")
    velocity.SetNumberOfComponents(3)
    radius = vtk.vtkDoubleArray()
    radius.SetName("radius")
    for i, h in enumerate(heights):
        points.InsertNextPoint(float(i), 0.0, h)
        velocity.InsertNextTuple3(1.0 * (i + 1), 0.0, 0.0)
        radius.InsertNextValue(0.5)
    poly = vtk.vtkPolyData()
    poly.SetPoints(points)
    poly.GetPointData().AddArray(velocity)
    poly.GetPointData().AddArray(radius)
    writer = vtk.vtkXMLPolyDataWriter()
    writer.SetFileName(path)
    writer.SetInputData(poly)
    writer.Write()


if __name__ == "__main__":
    main(sys.argv[1:])
