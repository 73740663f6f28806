"""What gshade runs on: a libLLVM for Dr.Jit, the Mitsuba variant, and native libraries'
console output captured around their calls."""
