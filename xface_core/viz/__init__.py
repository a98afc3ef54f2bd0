"""Presentation of the simulator's results: rerun recordings and pictures (the ``viz`` extra).

``pip install '.[viz]'`` in the xface checkout adds rerun-sdk, matplotlib and pillow; the
simulator needs none.
Importing this package imports nothing heavy: import the module you need.

- :mod:`xface_core.viz.recording`: rerun recordings (``.rrd``) of predictions and
  acceptance maps, with a viewer layout (rerun-sdk).
- :mod:`xface_core.viz.mapimage`: acceptance maps as PNG/SVG pictures (matplotlib).
- :mod:`xface_core.viz.benchplot`: the work-precision plot of ``xface bench`` (matplotlib).
- :mod:`xface_core.viz.facedraw`: a design's two parts, mated and at a start pose, as
  PNG/SVG pictures (matplotlib); :mod:`xface_core.viz.facecad`: the same as a DXF drawing
  for CAD (ezdxf, the ``cad`` extra).
- :mod:`xface_core.viz.heatmap`: a design search's criterion over H/D x r_p as a PNG
  heat map (matplotlib).
"""
