"""Render an mca VTK output (.pvd series or single .vtu) to a PNG with ParaView, and print what was read.

Usage (no display needed):
    xvfb-run -a pvbatch tools/pv_render.py OUT/series.pvd out.png [--field NAME] [--time last]
        [--size 1280x720] [--point-size 6]

--field   array to colour by, of the points or the cells (surface.pvd's fragment; vectors by magnitude;
          fragment by a hue of its own for each id); default: 'damage' if present, else the first
--time    'first', 'last' (default), a step index such as '#3', or a time value (the nearest step is used)

The printed summary (time steps, points, cells, arrays with ranges) is what ParaView itself read, which
makes this a check of the writer against the real client as well as a quick look at a run.
"""
import argparse
import math
import os
import sys

from paraview.simple import (Calculator, ColorBy, GetActiveViewOrCreate, GetColorTransferFunction,
                             GetDisplayProperties, OpenDataFile, PVDReader, ResetCamera, SaveScreenshot, Show,
                             UpdatePipeline)

# Arrays that number things (a fragment's id, heaviest first): coloured by a hue spread from the id, so that
# neighbouring ids (the largest pieces, 0, 1, 2, ...) differ, where a continuous map over 0..N-1 gave the
# first few of hundreds one blue.
LABEL_ARRAYS = {"fragment"}
GOLDEN = 0.6180339887498949


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("input", help=".pvd series or .vtu file")
    p.add_argument("png", help="PNG to write")
    p.add_argument("--field", default=None)
    p.add_argument("--time", default="last")
    p.add_argument("--size", default="1280x720")
    p.add_argument("--point-size", type=float, default=6.0, help="pixels, 0.5 to 100")
    return p.parse_args()


# vtkType.h codes of the array types mca writes.
VTK_TYPE_NAMES = {3: "UInt8", 6: "Int32", 10: "Float32", 11: "Float64", 12: "Int64"}


def fail(message):
    print(f"pv_render: {message}", file=sys.stderr)
    sys.exit(1)


def pick_time(times, spec):
    if not times:
        return None
    if spec == "first":
        return times[0]
    if spec == "last":
        return times[-1]
    if spec.startswith("#"):
        try:
            index = int(spec[1:])
        except ValueError:
            fail(f"--time {spec!r}: #INDEX takes a whole number, e.g. #3 (or -1 for the last)")
        if not -len(times) <= index < len(times):
            fail(f"--time {spec}: the series has {len(times)} steps")
        return times[index]
    try:
        wanted = float(spec)
    except ValueError:
        fail(f"--time {spec!r}: use first, last, #INDEX or a time value")
    if not math.isfinite(wanted):
        fail(f"--time {spec!r}: a time value is a finite number of seconds")
    return min(times, key=lambda t: abs(t - wanted))


def main():
    args = parse_args()
    if os.path.isdir(args.input):
        fail(f"{args.input} is a folder: give a file in it, e.g. {os.path.join(args.input, 'automata.pvd')}")
    if not os.path.isfile(args.input):
        fail(f"{args.input} does not exist")
    if not args.png.endswith(".png") or os.path.isdir(args.png):  # (ParaView's writer takes .png, not .PNG)
        fail(f"{args.png}: give a .png file to write")
    folder = os.path.dirname(os.path.abspath(args.png))
    if not os.path.isdir(folder):
        fail(f"{args.png}: its folder {folder} does not exist")
    if not (math.isfinite(args.point_size) and 0.5 <= args.point_size <= 100):
        fail(f"--point-size {args.point_size:g}: give 0.5 to 100 pixels")
    try:
        width, height = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        fail(f"--size {args.size!r}: use WIDTHxHEIGHT, e.g. 1280x720")
    if not (16 <= width <= 16384 and 16 <= height <= 16384):
        fail(f"--size {args.size}: give 16 to 16384 pixels each way")

    if args.input.lower().endswith(".pvd"):
        reader = PVDReader(FileName=os.path.abspath(args.input))
    else:
        try:
            reader = OpenDataFile(os.path.abspath(args.input))
        except RuntimeError as e:  # (ParaView raises where it has no reader for the file)
            fail(f"ParaView cannot read {args.input} ({e}): give an mca .pvd series or a .vtu/.vtp/.ply file")
    if reader is None:
        fail(f"ParaView has no reader for {args.input}")

    times = list(getattr(reader, "TimestepValues", None) or [])
    if isinstance(times, float):
        times = [times]
    time = pick_time(times, args.time)
    if time is None:
        UpdatePipeline(proxy=reader)
    else:
        UpdatePipeline(time=time, proxy=reader)

    info = reader.GetDataInformation()
    point_info = reader.PointData
    names = list(point_info.keys())
    # A frame the reader could not read (missing, cut short: ParaView logs its error and goes on) gives an
    # empty picture: as a check of what was written, that is a failure.
    if info.GetNumberOfPoints() == 0:
        fail(f"{args.input}: ParaView read no points at time {time if time is not None else 'n/a'} (see its error "
             "above: a frame file missing, cut short or damaged)")
    print(f"file: {args.input}")
    print(f"time steps: {len(times)}" + (f" ({', '.join(f'{t:g}' for t in times)})" if times else ""))
    print(f"shown time: {time if time is not None else 'n/a'}")
    print(f"points: {info.GetNumberOfPoints()}  cells: {info.GetNumberOfCells()}")
    # (The automata's arrays are the points'; the surface's fragment, surface.pvd, its triangles'.)
    cell_info = reader.CellData
    arrays = {name: ("POINTS", point_info[name]) for name in names}
    arrays.update({name: ("CELLS", cell_info[name]) for name in cell_info.keys() if name not in arrays})
    for title, where in (("point arrays", "POINTS"), ("cell arrays", "CELLS")):
        listed = [name for name, (w, _) in arrays.items() if w == where]
        if where == "CELLS" and not listed:
            continue
        print(f"{title}: {len(listed)}")
        for name in listed:
            array = arrays[name][1]
            ranges = ", ".join(f"[{lo:g}, {hi:g}]" for lo, hi in
                               (array.GetRange(c) for c in range(array.GetNumberOfComponents())))
            print(f"  {name}: {array.GetNumberOfComponents()} component(s) {VTK_TYPE_NAMES.get(array.GetDataType(), array.GetDataType())} range {ranges}")

    names = list(arrays)
    field = args.field or ("damage" if "damage" in names else (names[0] if names else None))
    if args.field and args.field not in names:
        fail(f"--field {args.field}: not an array here; choose one of {', '.join(names) or '(none)'}")

    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = [width, height]
    if time is not None:
        view.ViewTime = time
    shown = reader
    label = field in LABEL_ARRAYS
    if label:
        where = arrays[field][0]
        hue_name = f"{field}_hue"
        shown = Calculator(Input=reader, ResultArrayName=hue_name,
                           Function=f"{field}*{GOLDEN}-floor({field}*{GOLDEN})",
                           AttributeType="Point Data" if where == "POINTS" else "Cell Data")
        UpdatePipeline(proxy=shown, **({} if time is None else {"time": time}))
    display = Show(shown, view)
    # Vertex cells draw as points and the optional link lines as lines under 'Surface'.
    display.SetRepresentationType("Surface")
    display.PointSize = args.point_size
    display.RenderPointsAsSpheres = 1
    display.LineWidth = 1.0
    if field and label:
        ColorBy(display, (where, hue_name))
        lut = GetColorTransferFunction(hue_name)
        lut.ApplyPreset("Rainbow Uniform", True)
        lut.RescaleTransferFunction(0.0, 1.0)
        display.SetScalarBarVisibility(view, False)  # (a hue per id: no scale to read)
        print(f"coloured by: {field} (a hue per id)")
    elif field:
        where, array = arrays[field]
        components = array.GetNumberOfComponents()
        if components > 1:
            ColorBy(display, (where, field, "Magnitude"))
        else:
            ColorBy(display, (where, field))
        display.RescaleTransferFunctionToDataRange(False, True)
        display.SetScalarBarVisibility(view, True)
        print(f"coloured by: {field}" + (" (magnitude)" if components > 1 else ""))

    view.CameraPosition = [1.0, -1.6, 1.0]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    ResetCamera(view)
    # (ParaView logs a file it could not write and goes on: the file is checked, an old one first removed.)
    if os.path.exists(args.png):
        os.remove(args.png)
    SaveScreenshot(args.png, view, ImageResolution=[width, height])
    if not os.path.isfile(args.png) or os.path.getsize(args.png) == 0:
        fail(f"could not write {args.png} (see ParaView's error above)")
    print(f"wrote {args.png}")


main()
