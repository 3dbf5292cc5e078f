"""Hatching synthesis: tonal art maps of pencil strokes (Lee et al. 2006); see ``tam``."""
