/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

\*---------------------------------------------------------------------------*/

#include "interfaceTraction.H"
#include "DynamicList.H"

// * * * * * * * * * * * * * * * Global Functions  * * * * * * * * * * * * * //

namespace
{

// Median-dual weights of face f into w[0..n) (n = f.size()): triangle
// (c, p_k, p_k+1), half of it (split at the edge mid-point) to p_k, the other
// half to p_k+1, normalised to sum to one
template<class WeightList>
void faceWeights
(
    const Foam::face& f,
    const Foam::pointField& points,
    WeightList& w
)
{
    using namespace Foam;
    const point c = f.centre(points);
    const label n = f.size();
    for (label k = 0; k < n; ++k)
    {
        w[k] = 0;
    }
    scalar sumA = 0;
    for (label k = 0; k < n; ++k)
    {
        const point& a = points[f[k]];
        const point& b = points[f.nextLabel(k)];
        const scalar halfA = 0.25*mag((a - c) ^ (b - c));
        w[k] += halfA;
        w[(k + 1) % n] += halfA;
        sumA += 2*halfA;
    }

    if (sumA > VSMALL)
    {
        for (label k = 0; k < n; ++k)
        {
            w[k] /= sumA;
        }
    }
    else
    {
        for (label k = 0; k < n; ++k)
        {
            w[k] = 1.0/n;
        }
    }
}

} // End anonymous namespace


Foam::List<Foam::scalarList> Foam::tq::medianDualWeights
(
    const faceList& faces,
    const pointField& points
)
{
    List<scalarList> weights(faces.size());

    forAll(faces, facei)
    {
        weights[facei].setSize(faces[facei].size());
        faceWeights(faces[facei], points, weights[facei]);
    }

    return weights;
}


Foam::tmp<Foam::vectorField> Foam::tq::distributeMedianDual
(
    const faceList& faces,
    const pointField& points,
    const label nPoints,
    const vectorField& faceForces
)
{
    tmp<vectorField> tpf(new vectorField(nPoints, Zero));
    vectorField& pf = tpf.ref();
    DynamicList<scalar> w(16);

    forAll(faces, facei)
    {
        const face& f = faces[facei];
        w.setSize(f.size());
        faceWeights(f, points, w);
        forAll(f, k)
        {
            pf[f[k]] += w[k]*faceForces[facei];
        }
    }

    return tpf;
}


Foam::tmp<Foam::scalarField> Foam::tq::pointAreas
(
    const faceList& faces,
    const List<scalarList>& weights,
    const label nPoints,
    const scalarField& faceAreas
)
{
    tmp<scalarField> tpa(new scalarField(nPoints, 0.0));
    scalarField& pa = tpa.ref();

    forAll(faces, facei)
    {
        const face& f = faces[facei];
        const scalarList& w = weights[facei];
        forAll(f, k)
        {
            pa[f[k]] += w[k]*faceAreas[facei];
        }
    }

    return tpa;
}


// ************************************************************************* //
