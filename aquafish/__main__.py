from aquafish.cli import main

main()
