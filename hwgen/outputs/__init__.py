"""What people look at, made from the files and the checks' report: plots, the bill of
materials, the pictures and the drawing."""
