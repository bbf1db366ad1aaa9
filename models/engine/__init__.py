"""The engine every computation runs on: CasADi graphs of a structure, compiled to native code once, evaluated
over batches of poses; a `Runtime` owns them per structure, a `Registry` the runtimes. It knows robots only
as descriptions and imports nothing of the pipelines built on it.
"""
