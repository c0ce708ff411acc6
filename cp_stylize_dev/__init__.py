"""Development tools of cp_stylize, not shipped in the extension: the demo, the paper's figures, the benchmark.

``python -m cp_stylize demo|paper|bench`` runs them from a checkout.  The demo
and the scene helpers need Blender's Python module (``bpy``).
"""
