"""The one template of the interactive HTML reports (contents, unit selectors, plots; plotly.js
loaded from beside the pages) and the JSON form of report data, shared by every command's
report."""
