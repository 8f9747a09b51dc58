from manipcad.cli import main

main()
