/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

Description
    Registers laminarModel tqNewtonian for compressible flow (rhoPimpleFoam:
    the weakly compressible water) in the stock run-time table of laminar
    models of libcompressibleTurbulenceModels.so (turbulentFluidThermoModels.C
    defines it; the makeLaminarModel macro of turbulentFluidThermoModels.H
    adds one entry).

    The stock Stokes model's explicit term there is
        -div(mu dev2(T(grad U))) = -(mu/3) grad(div U)
    for a uniform mu, with div U = -(1/rho) D(rho)/Dt = -(1/K) Dp/Dt in the
    water: next to grad p, of relative size mu omega/(3 K), about 6e-12 for
    water (mu 1.3e-3 Pa s, K 2.2 GPa) shaken at 5 Hz.  The thermo must give
    a uniform mu: its transport must be 'const' (constTransport), checked
    at construction.

\*---------------------------------------------------------------------------*/

#include "turbulentFluidThermoModels.H"
#include "tqNewtonian.H"

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{
namespace laminarModels
{

template<>
void tqNewtonian<fluidThermoCompressibleTurbulenceModel>::checkNewtonian()
const
{
    // constTransport<...>::typeName() is "const<...>": the viscosity does
    // not depend on p or T
    const word name(this->transport().thermoName());
    if (name.compare(0, 6, "const<") != 0)
    {
        FatalErrorInFunction
            << "laminarModel " << typeName << " (constant/"
            << this->propertiesName << ") assumes a uniform viscosity, but"
            << " the thermo's transport is not 'const': " << name << nl
            << "    Use 'transport const;' in thermoType"
            << " (constant/thermophysicalProperties) or the stock"
            << " 'laminarModel Stokes;'." << nl
            << exit(FatalError);
    }
}

} // End namespace laminarModels
} // End namespace Foam


makeLaminarModel(tqNewtonian);

// ************************************************************************* //
